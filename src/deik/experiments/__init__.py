"""Reproductions of the paper's evaluation, one module per figure (or pair of figures).

Run them with `python -m deik.experiments NAME|all [--quick] --out DIR` (`deik.experiments.runner`):
fig2 (`fig2_chain`), fig3 (`fig3_population`), fig4 and fig5 (`fig45_humanoid`), fig6
(`fig6_comfort`), fig7 (`fig7_selection`), fig8 (`fig8_timing`) and fig9 (`fig9_speedup`).
Each experiment's `run(out_dir, quick, device)` writes NAME.png and NAME.csv and returns a
`common.Section` for the report; `timing` holds the serial/parallel timing shared with
`benchmarks/serial_vs_parallel.py`.
"""
