"""Goals a user asks for, the registry of goal kinds, the term table the kernels read, and its NumPy oracle."""
