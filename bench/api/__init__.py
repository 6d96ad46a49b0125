"""The plugin contract (cases, schemes, what passes between them), parameters, the registry,
and the finite-element assembly with scikit-fem."""
