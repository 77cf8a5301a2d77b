"""Tests of the replan latency benchmark (tools/bench_lib/latency.py)."""

from __future__ import annotations

import csv
import subprocess
import sys
from typing import TYPE_CHECKING

from ..factories import ROOT, bench_lib

if TYPE_CHECKING:
    from pathlib import Path


latency = bench_lib("latency")


def test_measure_times_both_goals() -> None:
    """Tests that one round measures both goals with sane figures."""
    runs = latency.measure(repeat=1, time_limit=10)
    assert [r.scenario for r in runs] == ["paper-goal", "ping-goal"]
    assert [r.repeat for r in runs] == [0, 0]
    assert runs[0].plan_id > 1  # plan 1 is the initial plan
    assert runs[1].plan_id > runs[0].plan_id
    for run in runs:
        assert run.status == "optimal"
        assert run.latency_s > 0
        assert run.solver_wall_s is not None
        assert run.overhead_s is not None
        # The solve happens inside the measured interval.
        assert run.latency_s >= run.solver_wall_s
        assert run.overhead_s == run.latency_s - run.solver_wall_s
    text = latency.format_latency(runs)
    assert "paper-goal" in text
    assert "ping-goal" in text


def test_format_latency_without_stats() -> None:
    """Tests that plans without solver statistics render as dashes."""
    runs = [
        latency.LatencyRun(
            "ping-goal", rep, 0.01 * (rep + 1), None, None, 2, "optimal"
        )
        for rep in range(3)
    ]
    row = next(
        line
        for line in latency.format_latency(runs).splitlines()
        if line.startswith("ping-goal")
    )
    assert row.split() == [
        "ping-goal",
        "3",
        "0.020",
        "0.028",
        "0.030",
        "-",
        "-",
    ]


def test_bench_latency_suite_writes_csv(tmp_path: Path) -> None:
    """Tests that tools/bench --suite latency prints the table, writes CSV."""
    result = subprocess.run(
        [
            sys.executable,
            str(ROOT / "tools" / "bench"),
            "--suite",
            "latency",
            "--repeat",
            "1",
            "--time-limit",
            "10",
            "--out",
            str(tmp_path),
        ],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert result.returncode == 0, result.stderr
    assert "replan latency" in result.stdout
    assert result.stderr.count("/2] ") == 2  # one progress line per run
    with (tmp_path / "latency.csv").open(newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert [r["scenario"] for r in rows] == ["paper-goal", "ping-goal"]
    assert (tmp_path / "latency.txt").read_text().startswith("Replan")
