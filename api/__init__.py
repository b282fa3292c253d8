"""The REST service (FastAPI): stored runs, schemes started and followed, jobs, reports, API
tokens, the operator console.

settings.py     one Settings object from RIG_* variables; app.py: create_app() (routers, body
                limit, worker pool)
deps.py, auth.py  store/settings/role dependencies; roles viewer < operator < rig-operator < admin
answers.py      the typed answers of the routes (their response_model)
routers/        one router per resource: runs, schemes (and acquisitions), jobs, reports, tokens,
                health, rig_model, console (the page at /, /docs and /redoc served offline, /me)
console/        the operator console's page, script and stylesheet
acquisition.py  the web side of scheme acquisitions; acquisition_process.py the process that
                runs each one (`python -m api.acquisition_process`)
job_kinds.py    the job kinds (parameters + function), one entry per kind; job_runtime.py, worker.py
                the worker processes and their supervised pool; dask_backend.py jobs on Dask
reports.py      run and job reports (JSON, HTML); run_plots.py, diagnosis_plots.py, fit_series.py,
                reproduction_plots.py their figures; response_cache.py the answer cache
The job queue's SQL is db/jobs.py; `rig serve` and `rig token` live in commands/
(docs/architecture.md)."""
