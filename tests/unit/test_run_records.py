"""The program service's record of its runs: a crash leaves a failed run, not an idle one,
and the leases the run took are handed back for release."""

from __future__ import annotations

from pathlib import Path

from openpendant.runtime.program.models import RunStatus
from openpendant.runtime.program.records import RunRecords


def test_a_run_live_at_a_crash_is_failed_with_the_reason_and_its_leases_returned(
    tmp_path: Path,
) -> None:
    path = tmp_path / "program-runs.json"
    records = RunRecords(path)
    records.update(RunStatus(program="pick", run=7, state="running"), {"robot": "tok"})
    records.update(RunStatus(program="done", run=6, state="finished"), {})
    assert path.stat().st_mode & 0o777 == 0o600

    after_crash = RunRecords(path)  # the service restarted
    assert after_crash.last_run() == 7
    assert after_crash.crashed() == [("pick", {"robot": "tok"})]
    status = after_crash.status("pick")
    assert status is not None and status.state == "error"
    assert status.error is not None and status.error.code == "service_crashed"
    assert "stopped during this run" in status.error.message
    finished = after_crash.status("done")
    assert finished is not None and finished.state == "finished"
    assert RunRecords(path).crashed() == []  # once only, and the tokens are gone
    assert "tok" not in path.read_text()
