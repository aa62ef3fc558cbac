"""The jig of a design as a true-scale SVG drawing (1 user unit = 1 mm), to print or machine."""

from __future__ import annotations

import numpy as np

from ..units import MM


def jig_svg(jig_xz, *, margin_mm: float = 3.0, stroke_mm: float = 0.3, label: str = "") -> str:
    """SVG text of the jig curve at true scale (1 user unit = 1 mm), to print or machine.

    The curve is ``jig_xz`` (m), drawn with z up (SVG's y axis points down, so it is flipped).
    The clamp end (s = 0) is marked by a small circle.
    """
    p = np.asarray(jig_xz, dtype=float) / MM
    x, y = p[:, 0], -p[:, 1]
    x0, x1, y0, y1 = x.min() - margin_mm, x.max() + margin_mm, y.min() - margin_mm, y.max() + margin_mm
    w, h = x1 - x0, y1 - y0
    pts = " ".join(f"{a:.4f},{b:.4f}" for a, b in zip(x, y, strict=True))
    title = f"<title>{label}</title>\n" if label else ""
    return (
        '<?xml version="1.0" encoding="UTF-8"?>\n'
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{w:.4f}mm" height="{h:.4f}mm" '
        f'viewBox="{x0:.4f} {y0:.4f} {w:.4f} {h:.4f}">\n'
        f"{title}"
        f'<polyline points="{pts}" fill="none" stroke="black" stroke-width="{stroke_mm}" '
        'stroke-linejoin="round" stroke-linecap="round"/>\n'
        f'<circle cx="{x[0]:.4f}" cy="{y[0]:.4f}" r="{2 * stroke_mm:.4f}" fill="red"/>\n'
        "</svg>\n"
    )


__all__ = ["jig_svg"]
