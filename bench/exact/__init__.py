"""Exact solutions and their fast evaluators: characteristics, d'Alembert, closed forms,
and a numerical reference from a fine run."""
