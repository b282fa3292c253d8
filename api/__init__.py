"""The REST service (FastAPI): stored runs, schemes started and followed, jobs, reports, API tokens.

settings.py  one Settings object from RIG_* variables     app.py      create_app(): routers, body limit, worker pool
deps.py      store/settings/role dependencies (aliases)    auth.py     roles viewer < operator < admin
routers/     one router per resource: runs, schemes, jobs, reports, tokens
acquisition.py  scheme acquisitions, each in a process of its own
job_kinds.py the job kinds (parameters + function); one entry per kind
queue.py     the durable job queue in SQL (claim, heartbeat, finish, fail, cancel, recovery)
worker.py    the worker process (`python -m api.worker`) and the pool the service starts
dask_backend.py  jobs on a Dask cluster
reports.py   run and job reports (JSON, HTML); run_plots.py, diagnosis_plots.py, fit_series.py  their figures
The `rig serve` and `rig token` commands live in commands/ (docs/architecture.md).
"""
