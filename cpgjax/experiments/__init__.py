"""Drivers that run things and write results: evolve / search, sweeps, studies, benchmarks, notebooks."""
