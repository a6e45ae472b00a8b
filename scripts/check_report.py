"""Check that a written report is whole: ``python -m scripts.check_report out/report/index.html``.

Exits non-zero, listing what is wrong, if the page is missing or links to a file that is not
there, or to anything outside the report folder (the report must open offline, moved anywhere),
or to an MP4 that browsers do not play (only H.264, ``avc1``, plays everywhere).
"""

from __future__ import annotations

import sys
from pathlib import Path

from common.video import BROWSER_CODECS, mp4_codecs
from scripts.report import referenced_files


def problems(index: Path) -> list[str]:
    """List what is wrong with the report at ``index`` (empty: nothing).

    Parameters
    ----------
    index : Path
        The report's ``index.html``.

    Returns
    -------
    list of str
        One line per problem.
    """
    if not index.is_file():
        return [f"{index} does not exist"]
    root = index.parent.resolve()
    out = []
    for ref in referenced_files(index.read_text(encoding="utf-8")):
        target = (root / ref).resolve()
        if "://" in ref or Path(ref).is_absolute() or not target.is_relative_to(root):
            out.append(f"{ref}: not a path inside {root}")
        elif not target.is_file():
            out.append(f"{ref}: missing")
        elif target.suffix.lower() == ".mp4":
            out += _video_problems(ref, target)
    return out


def _video_problems(ref: str, target: Path) -> list[str]:
    try:
        codecs = mp4_codecs(target)
    except (ValueError, OSError) as err:
        return [f"{ref}: not a readable MP4 ({err})"]
    if set(codecs) <= set(BROWSER_CODECS):
        return []
    return [f"{ref}: codec {', '.join(codecs)}; browsers play {', '.join(BROWSER_CODECS)} (H.264)"]


def main(argv: list[str] | None = None) -> int:
    """Check the report named on the command line, printing what is wrong.

    Parameters
    ----------
    argv : list of str or None, default None
        The arguments (the path of ``index.html``); None reads ``sys.argv[1:]``.

    Returns
    -------
    int
        The exit status: 0 when whole, 1 when something is wrong, 2 for a bad usage.
    """
    args = sys.argv[1:] if argv is None else argv
    if len(args) != 1:
        print("usage: python -m scripts.check_report PATH/TO/index.html", file=sys.stderr)
        return 2
    index = Path(args[0])
    found = problems(index)
    for p in found:
        print(f"check_report: {p}", file=sys.stderr)
    if not found:
        print(
            f"check_report: {index} and the {len(referenced_files(index.read_text()))} "
            "files it links are all there"
        )
    return 1 if found else 0


if __name__ == "__main__":
    raise SystemExit(main())
