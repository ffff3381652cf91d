"""Problems, settings, the DE engine, solve(), the reusable Solver, results, seeding and the serial reference."""
