"""Identification: pure computation, runs in, results out. Never imports api/ or drivers."""
