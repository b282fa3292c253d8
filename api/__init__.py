"""The REST service (FastAPI): runs, schemes, jobs, reports."""
