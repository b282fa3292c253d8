"""The SQL store (SQLAlchemy 2 + Alembic): rigs, runs, channels, samples, jobs, results."""
