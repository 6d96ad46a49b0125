"""Compiled machinery at the bottom: SIMD vectors, tridiagonal and SPIKE solves, sampling,
energy and the blow-up rule. Imports nothing of the project."""
