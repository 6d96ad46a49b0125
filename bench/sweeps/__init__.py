"""Sweeps over grids of configurations, the run cache, the published study, analysis."""
