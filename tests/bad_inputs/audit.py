"""Count what becomes of every input of the bad-input corpus: ``python tests/bad_inputs/audit.py``
(``-v``: list the inputs that are not refused in one line)."""

from __future__ import annotations

import collections
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))

from harness import load_cases, make_fixtures, run_case  # noqa: E402


def main() -> None:
    cases = load_cases()
    counts: dict[str, collections.Counter] = collections.defaultdict(collections.Counter)
    bad = []
    with tempfile.TemporaryDirectory() as root:
        places = make_fixtures(Path(root) / "fixtures")
        for case in cases:
            outcome = run_case(case, places, Path(root) / case["id"])
            kind = outcome.kind
            if kind == "one-line" and case["expect"] not in outcome.text:
                kind = "one-line, other message"
            counts[case["section"]][kind] += 1
            counts["ALL"][kind] += 1
            if kind != "one-line":
                bad.append((case["id"], kind, case, outcome.text))
    for section, c in counts.items():
        print(
            f"{section:12s} {sum(c.values()):4d} inputs: "
            + ", ".join(f"{n} {k}" for k, n in sorted(c.items()))
        )
    if "-v" in sys.argv:
        for cid, kind, case, text in bad:
            shown = {k: v for k, v in case.items() if k not in ("section", "id")}
            print(f"{cid} [{kind}] {str(shown)[:200]} -> {text[:300]!r}")


if __name__ == "__main__":
    main()
