"""The independent judge: hard cases made from the shared clips and measurements that share no
code with deik (their own BVH reader and writer, kinematics, body model and contact detector).

`rigs` reads, writes and poses BVH rigs of any family; `walk` makes a procedural walk whose
contacts are known; `cases` turns the shared clips into other rigs, speeds, scales and errors;
`clips` judges a cleaned clip and `retargets` a retarget. The tests and the clip and retarget
benchmarks (`benchmarks.clip_targets`, `benchmarks.retarget_quality`) measure deik with them.
"""
