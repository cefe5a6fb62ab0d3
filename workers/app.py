"""The Celery application: Redis broker, JSON only, late acknowledgement.

Start a worker with ``inkmotion worker`` (or ``celery -A inkmotion.workers.app worker``).
The configuration is computed from :func:`inkmotion.settings.load_settings` when Celery
first needs it, not at import, so the environment of the worker process decides it.

Reliability (Celery docs, "Optimizing" and the Redis broker page): a job is acknowledged
only after it finished (``task_acks_late``), a job whose worker process died is rejected
and requeued (``task_reject_on_worker_lost``), a worker reserves one job at a time
(``worker_prefetch_multiplier = 1``), and Redis redelivers a job whose worker vanished
after ``visibility_timeout`` seconds, which is set above the hard time limit so a job that
is merely slow is never delivered twice.
"""

from __future__ import annotations

import ssl
from typing import Any
from urllib.parse import parse_qs, urlsplit

from celery import Celery
from kombu import Exchange, Queue

from inkmotion.settings import Settings, load_settings

#: queues that always exist: optimisation (GPU-friendly) apart from robot simulation (CPU)
BASE_QUEUES = ("optimise", "simulate")
TASK_NAME = "inkmotion.run_job"


def queue_for(kind: str) -> str:
    """The queue a job of ``kind`` goes to: the one its job-kind plugin declares."""
    from inkmotion.jobs.kind import job_kind

    return str(job_kind(kind).queue)


def known_queues() -> tuple[str, ...]:
    """Every queue a worker may serve: the base queues and those the job kinds declare."""
    from inkmotion.plugin_host import host

    declared = {k.queue for k in host().plugins("job-kind").values()}
    return tuple(dict.fromkeys([*BASE_QUEUES, *sorted(declared - set(BASE_QUEUES))]))


def broker_ssl_options(url: str) -> dict[str, Any] | None:
    """``broker_use_ssl`` for a ``rediss://`` URL (certificates verified by default).

    The query string may already carry ``ssl_cert_reqs`` (Celery's own syntax); then the
    URL decides. Otherwise INKMOTION_BROKER_CA_CERTS / _CERTFILE / _KEYFILE may name files.
    """
    import os

    parts = urlsplit(url)
    if parts.scheme != "rediss":
        return None
    if "ssl_cert_reqs" in parse_qs(parts.query):
        return None
    opts: dict[str, Any] = {"ssl_cert_reqs": ssl.CERT_REQUIRED}
    for key, env in (("ssl_ca_certs", "INKMOTION_BROKER_CA_CERTS"),
                     ("ssl_certfile", "INKMOTION_BROKER_CERTFILE"),
                     ("ssl_keyfile", "INKMOTION_BROKER_KEYFILE")):
        if os.environ.get(env):
            opts[key] = os.environ[env]
    return opts


def celery_config(settings: Settings) -> dict[str, Any]:
    """The Celery configuration for ``settings``."""
    conf: dict[str, Any] = {
        "broker_url": settings.broker_url,
        "broker_connection_retry_on_startup": True,
        "broker_transport_options": {
            "visibility_timeout": settings.visibility_timeout,
            "unacked_restore_interval": settings.restore_interval,
            "unacked_restore_throttle": 1,
            "socket_connect_timeout": 5,
            "socket_timeout": 30,
            "health_check_interval": 25,
        },
        "task_serializer": "json",
        "result_serializer": "json",
        "accept_content": ["json"],
        "result_accept_content": ["json"],
        "event_serializer": "json",
        "task_ignore_result": True,  # the job store holds status and results
        "task_acks_late": True,
        "task_reject_on_worker_lost": True,
        "worker_prefetch_multiplier": 1,
        "worker_cancel_long_running_tasks_on_connection_loss": True,
        "task_soft_time_limit": settings.soft_time_limit,
        "task_time_limit": settings.time_limit,
        "task_queues": [Queue(q, Exchange("inkmotion", "direct"), routing_key=q)
                        for q in known_queues()],
        "task_default_queue": "optimise",
        "task_default_exchange": "inkmotion",
        "task_default_routing_key": "optimise",
        "task_routes": {TASK_NAME: {"queue": "optimise"}},
    }
    ssl_opts = broker_ssl_options(settings.broker_url)
    if ssl_opts is not None:
        conf["broker_use_ssl"] = ssl_opts
    return conf


def create_app(settings: Settings | None = None) -> Celery:
    """A Celery app; ``settings=None`` reads the environment lazily, on first use."""
    celery = Celery("inkmotion", include=["inkmotion.workers.tasks"])
    if settings is not None:
        celery.conf.update(celery_config(settings))
    else:
        celery.add_defaults(lambda: celery_config(load_settings()))
    return celery


app = create_app()
