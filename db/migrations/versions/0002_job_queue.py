"""Job queue columns: an Idempotency-Key per submission (unique, so a retried POST /jobs finds
the job it already made), the number of claims (attempts, for re-queue after a lost worker)
and the worker's process id (to tell a dead worker on this host).

Revision ID: 0002
Revises: 0001
Create Date: 2026-11-21
"""
from __future__ import annotations

from alembic import op
import sqlalchemy as sa


revision = '0002'
down_revision = '0001'
branch_labels = None
depends_on = None


def upgrade() -> None:
    with op.batch_alter_table('jobs', schema=None) as batch_op:
        batch_op.add_column(sa.Column('idempotency_key', sa.String(length=200), nullable=True))
        batch_op.add_column(sa.Column('attempts', sa.Integer(), nullable=False,
                                      server_default='0'))
        batch_op.add_column(sa.Column('worker_pid', sa.Integer(), nullable=True))
        batch_op.create_unique_constraint(batch_op.f('uq_jobs_idempotency_key'),
                                          ['idempotency_key'])


def downgrade() -> None:
    with op.batch_alter_table('jobs', schema=None) as batch_op:
        batch_op.drop_constraint(batch_op.f('uq_jobs_idempotency_key'), type_='unique')
        batch_op.drop_column('worker_pid')
        batch_op.drop_column('attempts')
        batch_op.drop_column('idempotency_key')
