"""`python -m urdfkb` runs the command-line interface."""

from urdfkb.kb_server.cli import main

raise SystemExit(main())
