"""Problems (built, or read from TOML: problem_file), settings, the DE engine, solve(), the reusable
Solver, results, seeding, and warmup() of the CPU kernels."""
