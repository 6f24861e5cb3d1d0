"""A host reference for FXAA (numpy float32, one pixel at a time): Lottes' FXAA 3.11 quality
steps as ``post/aa.py``'s docstring states them, written the plain way, every operation
rounded to float32 in the order the device does it, for the tests to compare against bit
for bit."""

from __future__ import annotations

import numpy as np

from warp_hybrid.post.aa import EDGE_THRESHOLD, EDGE_THRESHOLD_MIN, LUMA_WEIGHTS, SEARCH_STEP_PX, SUBPIX

F = np.float32


def code_luma(codes: np.ndarray) -> np.ndarray:
    """The luma of 8-bit sRGB codes (H, W, 3): per channel ``weight * (code * (1 / 255))``
    in float32, the three terms summed in channel order."""
    terms = [F(w) * (codes[..., k].astype(F) * F(1.0 / 255.0)) for k, w in enumerate(LUMA_WEIGHTS)]
    return (terms[0] + terms[1]) + terms[2]


def fxaa(codes: np.ndarray) -> np.ndarray:
    """FXAA of the 8-bit image ``codes`` (H, W, 3) -> uint8 (H, W, 3)."""
    h, w = codes.shape[:2]
    luma = code_luma(codes)

    def lum(x: int, y: int) -> np.float32:
        return luma[min(max(y, 0), h - 1), min(max(x, 0), w - 1)]

    def texel(x: int, y: int) -> np.ndarray:
        return codes[min(max(y, 0), h - 1), min(max(x, 0), w - 1)].astype(F) * F(1.0 / 255.0)

    def bilinear(fetch, px: np.float32, py: np.float32):  # noqa: ANN001, ANN202 (a luma or a colour)
        bx, by = px - F(0.5), py - F(0.5)
        x0f, y0f = np.floor(bx), np.floor(by)
        fx, fy = bx - x0f, by - y0f
        x0, y0 = int(x0f), int(y0f)
        top = fetch(x0, y0)
        if fx > 0:
            top = top * (F(1) - fx) + fetch(x0 + 1, y0) * fx
        if not fy > 0:
            return top
        bottom = fetch(x0, y0 + 1)
        if fx > 0:
            bottom = bottom * (F(1) - fx) + fetch(x0 + 1, y0 + 1) * fx
        return top * (F(1) - fy) + bottom * fy

    out = codes.copy()
    for y in range(h):
        for x in range(w):
            lc, lu, ld, ll, lr = lum(x, y), lum(x, y - 1), lum(x, y + 1), lum(x - 1, y), lum(x + 1, y)
            lmin, lmax = min(lc, lu, ld, ll, lr), max(lc, lu, ld, ll, lr)
            rng = lmax - lmin
            if not rng >= max(F(EDGE_THRESHOLD_MIN), lmax * F(EDGE_THRESHOLD)):
                continue
            lul, lur, ldl, ldr = lum(x - 1, y - 1), lum(x + 1, y - 1), lum(x - 1, y + 1), lum(x + 1, y + 1)
            lud, llr = lu + ld, ll + lr
            left, right, up, down = lul + ldl, lur + ldr, lul + lur, ldl + ldr
            edge_h = (abs(F(-2) * ll + left) + abs(F(-2) * lc + lud) * F(2)) + abs(F(-2) * lr + right)
            edge_v = (abs(F(-2) * lu + up) + abs(F(-2) * lc + llr) * F(2)) + abs(F(-2) * ld + down)
            horizontal = edge_h >= edge_v
            luma1, luma2 = (lu, ld) if horizontal else (ll, lr)
            g1, g2 = luma1 - lc, luma2 - lc
            gradient = F(0.25) * max(abs(g1), abs(g2))
            negative = abs(g1) >= abs(g2)
            step = F(-1) if negative else F(1)
            average = F(0.5) * ((luma1 if negative else luma2) + lc)
            cx, cy = F(x) + F(0.5), F(y) + F(0.5)
            bx, by = (cx, cy + F(0.5) * step) if horizontal else (cx + F(0.5) * step, cy)
            ox, oy = (F(1), F(0)) if horizontal else (F(0), F(1))
            ends = []
            for sign in (-1, 1):
                px, py = (bx - ox, by - oy) if sign < 0 else (bx + ox, by + oy)
                end = bilinear(lum, px, py) - average
                for s in SEARCH_STEP_PX[1:]:
                    if not abs(end) < gradient:
                        break
                    px, py = (px - ox * F(s), py - oy * F(s)) if sign < 0 else (px + ox * F(s), py + oy * F(s))
                    end = bilinear(lum, px, py) - average
                ends.append((px, py, end))
            (p1x, p1y, end1), (p2x, p2y, end2) = ends
            d1, d2 = (cx - p1x, p2x - cx) if horizontal else (cy - p1y, p2y - cy)
            nearer, dist = (end1, d1) if d1 < d2 else (end2, d2)
            offset = F(0.5) - dist / (d1 + d2) if (nearer < 0) != (lc < average) else F(0)
            low_pass = ((F(2) * (lud + llr) + left) + right) / F(12)
            sub1 = min(max(abs(low_pass - lc) / rng, F(0)), F(1))
            sub2 = (F(-2) * sub1 + F(3)) * sub1 * sub1
            offset = max(offset, sub2 * sub2 * F(SUBPIX))
            shift = offset * step
            colour = bilinear(texel, cx, cy + shift) if horizontal else bilinear(texel, cx + shift, cy)
            out[y, x] = (np.clip(colour, F(0), F(1)) * F(255) + F(0.5)).astype(np.int32).astype(np.uint8)
    return out
