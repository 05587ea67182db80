"""Free text a client has the server store (a reviewer's name, a model name): one line of printable text;
and errors, cut to a few KiB before they are kept or logged.

XML 1.0 cannot carry most control characters (not even escaped), U+FFFE or U+FFFF, nor UTF-8 a lone
surrogate (which JSON's "\\ud800" makes): stored, one would make the robot's .owl export ill-formed or
answer 500. Such text is refused, naming the field, as is any other control character (line breaks,
C1 controls): a name needs none.
"""
from __future__ import annotations

import re

from urdfkb.limits import MAX_ERROR

_UNSTORABLE = re.compile("[\x00-\x1f\x7f-\x9f\ud800-\udfff\ufffe\uffff]")


def check_text(field: str, value: str) -> str:
    """`value` if it holds no control character, lone surrogate, U+FFFE or U+FFFF; ValueError naming `field` otherwise."""
    if (bad := _UNSTORABLE.search(value)) is not None:
        raise ValueError(f"{field} must be text without control characters or lone surrogates "
                         f"(found U+{ord(bad.group()):04X})")
    return value


def cut(text: str, limit: int = MAX_ERROR) -> str:
    """`text`, or its first `limit` characters and how long it was: an error kept or logged (a xacro's can
    run to megabytes) stays a few KiB."""
    if len(text) <= limit:
        return text
    return f"{text[:limit]}... [cut: {len(text):,} characters in all]"
