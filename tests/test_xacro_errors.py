"""A xacro's error is cut where it is made: in the child that expands it (xacro echoes what it could not
evaluate: a 177-byte document made a 19 MB error), and a child's stderr is kept as its last few KiB, so the
server never holds such a text whole (benchmarks/job_error_bench.py measures its memory)."""
from __future__ import annotations

import sys

import pytest

from urdfkb.pipeline.reading import sandbox
from urdfkb.pipeline.reading.xacro_input import XacroError, expand
from urdfkb.settings import MAX_ERROR


def failing(characters: int) -> bytes:
    """A xacro whose expansion fails with a KeyError naming a string of `characters` characters."""
    return f"""<robot name="big" xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:property name="s" value="${{'a' * {characters}}}"/>
  <xacro:property name="d" value="${{dict(b=1)}}"/>
  <link name="${{d[s]}}"/>
</robot>""".encode()


def test_a_huge_xacro_error_leaves_the_child_cut_saying_how_long_it_was():
    with pytest.raises(XacroError) as caught:
        expand(failing(2_000_000), "big.xacro")
    message = str(caught.value)
    assert message.startswith("big.xacro:4: 'aaaa") and message.endswith("... [cut: 2,000,049 characters in all]")
    assert len(message) <= MAX_ERROR // 2  # room for what the server says before it (kb_server.routes.jobs)


def test_a_short_xacro_error_is_whole():
    with pytest.raises(XacroError, match=r"^big.xacro:4: 'aaaaaaaaaa' when evaluating expression 'd\[s\]'$"):
        expand(failing(10), "big.xacro")


def test_a_child_s_output_is_kept_as_stdout_s_head_and_stderr_s_tail():
    flood = ("import sys\nfor _ in range(20): sys.stderr.write('x' * 1_000_000)\n"
             "sys.stderr.write('Error: the last line')\nsys.stdout.write('head' + 'y' * 1_000_000)")
    code, out, err = sandbox.bounded_run([sys.executable, "-c", flood], b"", 60, 100_000)
    assert code == 0 and out == b"head" + b"y" * (100_000 - 4)
    assert len(err) == MAX_ERROR and err.endswith(b"xError: the last line")
