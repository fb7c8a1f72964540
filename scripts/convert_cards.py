"""Rewrite checkpoint cards written before ``training_data`` named its datasets (once, no retraining).

``python scripts/convert_cards.py [CHECKPOINT_DIR]`` (default ``checkpoints/``) rewrites every
``*.json`` beside a ``.safetensors`` with ``ftin.train.provenance.convert_card``: datasets by name,
recordings relative to the data folder, no absolute path of the training machine. The weights and
their hash are not touched; a card already converted is left as it is. Each ``*.md`` card is checked
to hold no absolute path either.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from ftin.files import atomic_write_text
from ftin.train.provenance import absolute_paths_in, convert_card


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else argv
    folder = Path(args[0] if args else "checkpoints")
    for path in sorted(folder.glob("*.json")):
        meta = json.loads(path.read_text())
        converted = convert_card(meta)
        if converted != meta:
            atomic_write_text(path, json.dumps(converted, indent=2) + "\n")
            print(f"{path}: datasets {converted['training_data']['datasets']}")
        left = absolute_paths_in(converted)
        if left:
            print(f"{path}: absolute paths left: {left[:3]}", file=sys.stderr)
            return 1
    for path in sorted(folder.glob("*.md")):
        if any(word.startswith(("/work", "/home", "/Users")) for word in path.read_text().split()):
            print(f"{path}: holds an absolute path", file=sys.stderr)
            return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
