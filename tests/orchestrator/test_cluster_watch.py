"""``ClusterWatch`` against two listening sockets standing in for the GCS and this node's
raylet (issue 37): a raylet that goes is a lost cluster within about a second, a GCS that
goes one after its patience, and a loss nobody claims is ended by the watch itself."""

from __future__ import annotations

import socket
import threading
import time
from collections.abc import Iterator

import pytest

from orchestrator._campaign.cluster import ClusterWatch


class Listener:
    """A TCP port that accepts connections until ``close``."""

    def __init__(self) -> None:
        self.sock = socket.socket()
        self.sock.bind(("127.0.0.1", 0))
        self.sock.listen(16)
        self.addr = self.sock.getsockname()
        threading.Thread(target=self._accept, daemon=True).start()

    def _accept(self) -> None:
        while True:
            try:
                conn, _ = self.sock.accept()
            except OSError:
                return
            conn.close()

    def close(self) -> None:
        try:
            self.sock.shutdown(socket.SHUT_RDWR)  # wakes the accept (close alone does not)
        except OSError:
            pass
        self.sock.close()


@pytest.fixture
def gcs() -> Iterator[Listener]:
    listener = Listener()
    yield listener
    listener.close()


@pytest.fixture
def raylet() -> Iterator[Listener]:
    listener = Listener()
    yield listener
    listener.close()


def _watch(gcs: Listener, raylet: Listener | None, **kw: object) -> ClusterWatch:
    return ClusterWatch(f"{gcs.addr[0]}:{gcs.addr[1]}", kw.pop("patience_s", 30.0),  # type: ignore[arg-type]
                        raylet=None if raylet is None else raylet.addr, **kw)  # type: ignore[arg-type]


def _lost_within(watch: ClusterWatch, seconds: float) -> float:
    start = time.monotonic()
    assert watch.lost.wait(seconds), f"not lost within {seconds} s"
    return time.monotonic() - start


def test_a_gone_raylet_is_a_lost_cluster_within_seconds(gcs: Listener, raylet: Listener) -> None:
    watch = _watch(gcs, raylet, interval_s=0.2)
    try:
        time.sleep(0.5)
        assert not watch.lost.is_set() and watch.confirm(settle_s=0.1)
        raylet.close()
        _lost_within(watch, 3.0)  # the GCS still answers: its patience plays no part
        assert "raylet" in watch.reason and str(raylet.addr[1]) in watch.reason
    finally:
        watch.close()


def test_a_gone_gcs_is_a_lost_cluster_after_its_patience(gcs: Listener, raylet: Listener) -> None:
    watch = _watch(gcs, raylet, patience_s=1.0, interval_s=0.2)
    try:
        gcs.close()
        took = _lost_within(watch, 5.0)
        assert took >= 1.0
        assert "GCS" in watch.reason and "refused connections for 1 s" in watch.reason
    finally:
        watch.close()


def test_confirm_sees_a_cluster_that_went_meanwhile(gcs: Listener, raylet: Listener) -> None:
    """A task failed and the cluster answered once more as it was being killed: the second
    look, a moment later, says the cluster is gone."""
    watch = _watch(gcs, raylet, interval_s=60.0)  # the thread plays no part
    try:
        threading.Timer(0.2, raylet.close).start()
        assert not watch.confirm(settle_s=0.5)
        assert watch.lost.is_set() and "raylet" in watch.reason
    finally:
        watch.close()


def test_a_raylet_that_never_answered_is_not_watched(gcs: Listener) -> None:
    with socket.socket() as s:  # a port nobody listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    watch = ClusterWatch(f"{gcs.addr[0]}:{gcs.addr[1]}", 30.0, raylet=("127.0.0.1", port),
                         interval_s=0.1)
    try:
        assert watch.raylet is None
        assert not watch.lost.wait(0.6)
    finally:
        watch.close()


def test_a_loss_nobody_claims_is_ended_by_the_watch(gcs: Listener, raylet: Listener) -> None:
    """The driver's thread waits in a Ray call and never looks: after the grace, the watch
    calls ``on_stuck`` (the driver's ending without Ray), once."""
    called = threading.Event()
    watch = _watch(gcs, raylet, interval_s=0.1, grace_s=0.5, on_stuck=called.set)
    try:
        raylet.close()
        _lost_within(watch, 3.0)
        assert called.wait(3.0)
        assert not watch.claim()  # the driver's thread, should it wake, leaves it to the watch
    finally:
        watch.close()


def test_a_claimed_loss_is_left_to_the_driver(gcs: Listener, raylet: Listener) -> None:
    called = threading.Event()
    watch = _watch(gcs, raylet, interval_s=0.1, grace_s=0.5, on_stuck=called.set)
    try:
        raylet.close()
        _lost_within(watch, 3.0)
        assert watch.claim()
        assert not called.wait(1.5)
    finally:
        watch.close()


def test_a_call_that_waits_for_a_lost_cluster_ends_in_cluster_lost(gcs: Listener,
                                                                   raylet: Listener) -> None:
    """A Ray call that would wait for the dead GCS (``ray.nodes()`` does, until Ray's own
    abort) is waited for in slices: ClusterLost as soon as the cluster is lost."""
    from orchestrator._campaign.cluster import ClusterLost

    watch = _watch(gcs, raylet, interval_s=0.1, grace_s=30.0)
    never = threading.Event()
    try:
        assert watch.call(lambda a, b: a + b, 2, 3) == 5
        with pytest.raises(ZeroDivisionError):
            watch.call(lambda: 1 / 0)
        with pytest.raises(TimeoutError):
            watch.call(never.wait, timeout_s=0.6)
        threading.Timer(0.3, raylet.close).start()
        start = time.monotonic()
        with pytest.raises(ClusterLost, match="raylet"):
            watch.call(never.wait)
        assert time.monotonic() - start < 3.0
    finally:
        never.set()
        watch.close()
