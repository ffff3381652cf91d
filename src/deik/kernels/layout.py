"""Names for the data the kernels read: sizes and limits shared by the CPU and CUDA back-ends."""

THREADS_PER_BLOCK = 128  # GPU threads per problem (one block each)
MAX_POLISH_COUNT = THREADS_PER_BLOCK  # individuals one polish round may refine: one GPU thread each
