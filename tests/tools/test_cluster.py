"""``shoal campaign --dask ADDRESS``: the same fields on a Dask cluster give the local run's
outcomes, field for field, and the same report; here the cluster is a local one of two worker
processes on loopback (tools/campaign/cluster.py)."""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Iterator
from typing import Any

import pytest
from click.testing import CliRunner
from distributed import LocalCluster

from shoal.tools.campaign import cluster
from shoal.tools.campaign.cluster import ClusterError, run_on_dask
from shoal.tools.campaign.fields import FieldOptions
from shoal.tools.campaign.runner import run_campaign, run_task, tasks
from shoal.tools.cli import main
from shoal.tools.procs.launch import free_port
from shoal.world.loader import load_scenario

# What differs between two runs of the same campaign: the clock and where it ran.
TIMING = {"wall_s", "fields_per_s", "cpu_s_per_field", "jobs", "cpu_s", "seconds"}


@pytest.fixture(scope="module")
def scheduler() -> Iterator[str]:
    with LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
        scheduler_port=0, dashboard_address=None,
    ) as cluster:  # fmt: skip
        yield str(cluster.scheduler_address)


def _untimed(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _untimed(v) for k, v in value.items() if k not in TIMING}
    if isinstance(value, list):
        return [_untimed(v) for v in value]
    return value


def test_the_cluster_gives_every_fields_outcome_of_the_local_run(scheduler: str) -> None:
    todo = tasks(load_scenario("obstacles"), 0, 2, 1, FieldOptions())[:3]  # one outside
    done: list[object] = []
    remote, threads = run_on_dask(todo, scheduler, done.append, run_task)
    local = run_campaign(todo, 1)
    assert threads == 2 and len(done) == len(todo) == len(remote)
    assert len({o.mode for o in remote}) > 1  # inside and outside fields both
    unclocked = [dataclasses.replace(o, seconds=0.0) for o in remote]
    assert unclocked == [dataclasses.replace(o, seconds=0.0) for o in local]


def test_shoal_campaign_on_the_cluster_prints_the_local_report(scheduler: str) -> None:
    args = ["campaign", "--fields", "2", "--no-outside", "--json"]
    on_cluster = CliRunner().invoke(main, [*args, "--dask", scheduler])
    here = CliRunner().invoke(main, [*args, "--jobs", "1"])
    assert on_cluster.exit_code == here.exit_code == 0, on_cluster.output + here.output
    remote, local = json.loads(on_cluster.stdout), json.loads(here.stdout)
    assert remote["jobs"] == 2 and local["jobs"] == 1
    assert _untimed(remote) == _untimed(local)


def test_no_scheduler_is_a_clear_error(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(cluster, "CONNECT_TIMEOUT_S", 1.0)  # nothing listens: no need to wait
    address = f"tcp://127.0.0.1:{free_port()}"
    with pytest.raises(ClusterError, match="no Dask scheduler at"):
        run_on_dask([], address, lambda _o: None, run_task)
    result = CliRunner().invoke(main, ["campaign", "--fields", "1", "--dask", address])
    assert result.exit_code == 1 and "no Dask scheduler at" in result.output
    assert "Traceback" not in result.output
