"""The sidebar's TM-30 colour vector graphic of an estimate, as a PNG (README's picture).

    python tools/draw_vector_graphic.py RESULT.json OUT.png [--size 256]

The same drawing the Blender panel shows (``core/rendition/vector_graphic.py``), from a result
file of ``estimate --json`` (its first estimate).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
from PIL import Image

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from cd_spectra_addon.core.rendition.vector_graphic import vector_graphic_image  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("result", type=Path)
    parser.add_argument("out", type=Path)
    parser.add_argument("--size", type=int, default=256)
    args = parser.parse_args(argv)
    data = json.loads(args.result.read_text(encoding="utf-8"))
    estimate = data[0] if isinstance(data, list) else data
    image = vector_graphic_image(estimate.get("rendition") or {}, args.size)
    if image is None:
        raise SystemExit(f"error: {args.result} has no colour rendition to draw")
    rgb = (np.clip(image[::-1, :, :3], 0.0, 1.0) * 255 + 0.5).astype(np.uint8)  # top row first in a PNG
    args.out.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(rgb).save(args.out, optimize=True)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
