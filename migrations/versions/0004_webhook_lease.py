"""a lease and the backoff time on job webhooks, so pending hooks are resent after a crash (issue 22)

Revision ID: 0004_webhook_lease
Revises: 0003_webhooks
Create Date: 2026-12-02 18:30:00
"""
from alembic import op
import sqlalchemy as sa

revision = '0004_webhook_lease'
down_revision = '0003_webhooks'
branch_labels = None
depends_on = None


def upgrade() -> None:
    with op.batch_alter_table('job_webhooks', schema=None) as batch_op:
        batch_op.add_column(sa.Column('delivery_id', sa.String(length=32), nullable=True))
        batch_op.add_column(sa.Column('claimed_by', sa.String(length=200), nullable=True))
        batch_op.add_column(sa.Column('lease_until', sa.DateTime(timezone=True), nullable=True))
        batch_op.add_column(sa.Column('next_attempt_at', sa.DateTime(timezone=True), nullable=True))
        batch_op.create_index(batch_op.f('ix_job_webhooks_state'), ['state'], unique=False)


def downgrade() -> None:
    with op.batch_alter_table('job_webhooks', schema=None) as batch_op:
        batch_op.drop_index(batch_op.f('ix_job_webhooks_state'))
        batch_op.drop_column('next_attempt_at')
        batch_op.drop_column('lease_until')
        batch_op.drop_column('claimed_by')
        batch_op.drop_column('delivery_id')
