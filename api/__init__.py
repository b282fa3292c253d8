"""The REST service (FastAPI): stored runs, jobs, reports, API tokens.

settings.py  one Settings object from RIG_* variables     app.py      create_app(): routers, body limit, worker pool
deps.py      store/settings/role dependencies (aliases)    auth.py     roles viewer < operator < admin
routers/     one router per resource: runs, jobs, reports, tokens
job_kinds.py the job kinds (parameters + function); one entry per kind
queue.py     the durable job queue in SQL (claim, heartbeat, finish, fail, cancel, recovery)
worker.py    the worker process (`python -m api.worker`) and the pool the service starts
reports.py   run and job reports (JSON, HTML);  run_plots.py  the run report's figures
cmd_serve.py `rig serve`;  cmd_token.py  `rig token create --role ROLE`
"""
