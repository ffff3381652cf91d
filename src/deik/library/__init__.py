"""Whole libraries of clips: every clip of a folder as a job, resumable (a clip done before with
the same settings and input is skipped), on local worker processes or a Ray cluster, with
progress and one summary (`deik clip DIR --out OUTDIR`, `deik retarget DIR ... --out OUTDIR`)."""
