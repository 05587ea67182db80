#!/usr/bin/env python3
"""A dialogue loop: ask a robot held by a running urdfkb server questions in words, and print (speak) the
sentence each answer gives, refusals included.

    urdfkb serve --populate pr2.urdf &
    python examples/dialogue.py --robot pr2                          # questions from the keyboard
    python examples/dialogue.py --robot pr2 "how far can your left arm reach?" "will it rain?"

The server's model chooses the bundled query for each question (urdfkb.client.KnowledgeBase.ask); the
sentence is made from the query's rows by code. Exit status 0 at the end of the questions, 1 when the
server could not be asked, 2 for bad arguments.
"""
from __future__ import annotations

import argparse
import sys

from urdfkb.client import ClientError, KnowledgeBase


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Ask a robot in a running urdfkb server questions in words.")
    parser.add_argument("questions", nargs="*", help="questions to ask (default: read lines from stdin)")
    parser.add_argument("--url", default="http://127.0.0.1:8000", help="the server (default: %(default)s)")
    parser.add_argument("--robot", required=True, help="the robot's name in the server")
    parser.add_argument("--token", help="bearer token, where the server or a proxy in front wants one")
    args = parser.parse_args(argv)
    try:
        kb = KnowledgeBase(args.url, token=args.token)
    except ValueError as e:
        parser.error(str(e))
    for question in args.questions or (line.strip() for line in sys.stdin):
        if not question:
            continue
        print(f"> {question}")
        try:
            print(kb.ask(args.robot, question).answer, flush=True)
        except ClientError as e:
            print(f"cannot ask: {e}", file=sys.stderr)
            return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
