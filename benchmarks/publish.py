"""How a benchmark publishes its result: ``<stem>.json`` (with its provenance) and ``<stem>.md`` landing together,
then stdout."""

from __future__ import annotations

import sys
from pathlib import Path

from jaxdc.io import atomic_write_set, json_text
from jaxdc.provenance import provenance


def publish(out_dir: Path, stem: str, result: dict, md: str, as_json: bool) -> None:
    """Write the table's JSON (strict) and markdown as one set; print the JSON line (the markdown to stderr)
    with ``as_json``, else the markdown."""
    atomic_write_set({Path(out_dir) / f"{stem}.json": json_text({**result, "provenance": provenance()}) + "\n",
                      Path(out_dir) / f"{stem}.md": md + "\n"})
    if as_json:
        print(json_text(result, indent=None))
        print(md, file=sys.stderr, flush=True)
    else:
        print(md)
