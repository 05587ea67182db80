"""The server test_crash_recovery kills: `python -m tests.crash_server STORE PORT` from the repository.

Its test-only hooks wrap build_robot (for the robot named in URDFKB_TEST_HANG_ON) and Store._persist
(for an update writing the graph named in URDFKB_TEST_HANG_ON) so that they touch the file named in
URDFKB_TEST_MARKER and sleep *inside* the store lock and the open SQLite transaction (old content
destroyed, new written, nothing committed).
"""
import os
import sys
import time
from unittest.mock import patch

import urdfkb.kb_server.store as store_mod
from tests.kb_fixtures import PR2, fake_runner
from urdfkb.kb_server.serve import make_server

HANG_ON, MARKER = os.environ.get("URDFKB_TEST_HANG_ON") or None, os.environ.get("URDFKB_TEST_MARKER", "")
real_build, real_persist = store_mod.build_robot, store_mod.Store._persist


def hang() -> None:
    open(MARKER, "w").close()
    time.sleep(3600)


def build_then_hang(world, tree, name, *args, **kw):
    onto = real_build(world, tree, name, *args, **kw)
    if name == HANG_ON:
        hang()
    return onto


def persist_then_hang(self, graph, data):
    real_persist(self, graph, data)
    if graph == HANG_ON:
        hang()


if __name__ == "__main__":  # not in the query workers, which import this module again (spawn)
    with patch.object(store_mod, "build_robot", build_then_hang), patch.object(store_mod.Store, "_persist", persist_then_hang):
        server, store, jobs = make_server(sys.argv[1], port=int(sys.argv[2]), runner=fake_runner({"pr2": PR2}), token="t")
        server.run()
