"""A scheduler address never hangs a run (ehsa_opt/utils/cluster.py): an unsupported
scheme, a server that is not a Dask scheduler and a scheduler without workers each end
with exit 2 within a few seconds, naming the address and the fix."""

from __future__ import annotations

import socket
import threading
import time

import pytest

from ehsa_opt.cli import main
from ehsa_opt.utils import cluster
from tests.paths import ROOT

SWEEP = ROOT / "problems/paper_design.toml"


def sweep(capsys, tmp_path, address: str) -> tuple[int, str, float]:
    t0 = time.monotonic()
    rc = main(["sweep", str(SWEEP), "--scheduler", address, "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert "Traceback" not in err
    return rc, err, time.monotonic() - t0


@pytest.fixture
def silent_server():
    """A local TCP server that accepts connections and never answers (an HTTP server
    waiting for a request line looks the same to a Dask client)."""
    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(8)
    held: list[socket.socket] = []

    def serve() -> None:
        while True:
            try:
                held.append(srv.accept()[0])
            except OSError:
                return
    threading.Thread(target=serve, daemon=True).start()
    yield f"tcp://127.0.0.1:{srv.getsockname()[1]}"
    srv.close()
    for c in held:
        c.close()


def test_ucx_address_is_refused_at_once(capsys, tmp_path):
    address = "ucx://127.0.0.1:8786"
    rc, err, dt = sweep(capsys, tmp_path, address)
    assert rc == 2 and address in err and "tcp://127.0.0.1:8786" in err, err
    assert "'ucx://' is not supported" in err and dt < 5.0
    assert not (tmp_path / "o").exists()


def test_a_server_that_is_not_a_dask_scheduler(capsys, tmp_path, silent_server):
    rc, err, dt = sweep(capsys, tmp_path, silent_server)
    assert rc == 2 and silent_server in err, err
    assert "no Dask scheduler answered" in err and "e.g. tcp://" in err
    assert dt < cluster.CONNECT_TIMEOUT_S + 5.0


def test_a_scheduler_without_workers(capsys, tmp_path):
    from distributed import LocalCluster
    with LocalCluster(n_workers=0, processes=False, dashboard_address=None,
                      protocol="tcp://") as lc:
        rc, err, dt = sweep(capsys, tmp_path, lc.scheduler_address)
    assert rc == 2 and lc.scheduler_address in err, err
    assert "has no worker" in err and "dask worker" in err
    assert cluster.WORKER_WAIT_S <= dt < cluster.WORKER_WAIT_S + 5.0


def test_nothing_listening(capsys, tmp_path):
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    address = f"tcp://127.0.0.1:{s.getsockname()[1]}"
    s.close()  # a free port
    rc, err, dt = sweep(capsys, tmp_path, address)
    assert rc == 2 and address in err and "cannot connect" in err, err
    assert dt < cluster.CONNECT_TIMEOUT_S + 5.0
