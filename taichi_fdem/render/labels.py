"""Text on images: the colour bar, its labels and the time stamp of
:class:`~taichi_fdem.render.RendererImage` (drawn with Pillow), and :func:`annotate`.

Labels are rendered once per distinct text into cached sprites and composited on their own
boxes, which gives the same pixels as drawing everything on one full-frame layer.
"""
import math

import numpy as np

from ._util import _as_uint8_image
from .colors import colormap

__all__ = ["annotate"]


def _fmt(v):
    return f"{v:.3g}"


class _Overlays:
    """The overlay methods of :class:`~taichi_fdem.render.RendererImage` (a mixin: the state,
    ``width``, ``height``, ``text_size``, ``cmap``, ``_font``, ``_sprites`` and ``_grad``, is set
    up by the renderer's ``__init__``)."""

    def _text_px(self):
        return self.text_size if self.text_size is not None else max(10, self.height // 30)

    def _get_font(self):
        size = self._text_px()
        if self._font is None or self._font[0] != size:
            from PIL import ImageFont

            try:
                font = ImageFont.load_default(size=size)
            except TypeError:  # Pillow < 10.1: fixed-size bitmap font
                font = ImageFont.load_default()
            self._font = (size, font)
        return self._font[1]

    def _bar_layout(self):
        """Pixel geometry of the colour bar: strip columns [x0, x1), rows [y0, y1) and the width
        reserved at the right of the image for strip and labels."""
        W, H = self.width, self.height
        ts = self._text_px()
        bw = max(6, min(W // 40, 30))
        x1 = W - max(4, ts // 2)
        x0 = x1 - bw
        y0 = min(H - 2, int(0.5 * ts) * 2 + ts + 4)   # room for the title above
        y1 = max(y0 + 2, H - ts - 4)
        label_w = int(5.5 * ts)                       # about "-1.23e+05"
        return {"x0": x0, "x1": x1, "y0": y0, "y1": y1, "reserve": min(W // 2, W - x0 + label_w + 6)}

    def _label_sprite(self, text, anchor):
        """A label (text on a translucent white box) rendered once per distinct text with PIL:
        ``(dx, dy, RGBA image)``, the box's top-left relative to the anchor point.  Glyph
        rasterisation is invariant under integer shifts, so pasting the sprite gives the same
        pixels as drawing the label in place."""
        size = self._text_px()
        key = (text, anchor, size)
        sp = self._sprites.get(key)
        if sp is None:
            from PIL import Image, ImageDraw

            font = self._get_font()
            probe = ImageDraw.Draw(Image.new("RGBA", (1, 1)))
            l, t, r, b = probe.textbbox((0, 0), text, font=font, anchor=anchor)
            dx, dy = int(l) - 2, int(t) - 2          # the box (l-2, t-2, r+2, b+2), inclusive
            w, h = int(r) - int(l) + 5, int(b) - int(t) + 5
            layer = Image.new("RGBA", (w, h), (0, 0, 0, 0))
            draw = ImageDraw.Draw(layer)
            draw.rectangle((0, 0, w - 1, h - 1), fill=(255, 255, 255, 170))
            draw.text((-dx, -dy), text, font=font, fill=(0, 0, 0, 255), anchor=anchor)
            if len(self._sprites) >= 512:            # auto-range labels change every frame
                self._sprites.clear()
            sp = self._sprites[key] = (dx, dy, layer)
        return sp

    def _gradient(self, rows):
        key = (rows, self.cmap)
        g = self._grad.get(key)
        if g is None:
            grad = colormap(np.linspace(1.0, 0.0, rows), 0.0, 1.0, self.cmap)   # top row = vmax
            g = self._grad[key] = np.clip(grad * 255.0 + 0.5, 0, 255).astype(np.uint8)
        return g

    def _overlay(self, img, bar, layout, stamp):
        """Colour bar, its labels and the stamp, drawn on small crops only (labels are cached
        sprites composited with PIL on their own box); the result equals drawing everything on
        one full-frame RGBA layer and compositing it."""
        from PIL import Image

        H, W = img.shape[:2]
        if not img.flags.writeable:
            img = np.array(img, copy=True)
        labels = []
        if bar is not None:
            vmin, vmax, title = bar
            x0, x1, y0, y1 = layout["x0"], layout["x1"], layout["y0"], layout["y1"]
            grad8 = self._gradient(y1 - y0)
            img[y0:y1, x0:x1] = grad8[:, None, :]
            labels += [((x0 - 4, y0), _fmt(vmax), "ra"), ((x0 - 4, y1), _fmt(vmin), "rd"),
                       ((x1, max(0, y0 - 6)), title, "rd")]
        if stamp is not None:
            labels.append(((4, 4), stamp, "la"))
        # every label box composited over the frame as it was before any label (a later label
        # replaces an earlier one where boxes overlap, as on a shared layer)
        jobs = []
        for (x, y), text, anchor in labels:
            dx, dy, sprite = self._label_sprite(text, anchor)
            bx0, by0 = x + dx, y + dy
            cx0, cy0 = max(bx0, 0), max(by0, 0)
            cx1, cy1 = min(bx0 + sprite.width, W), min(by0 + sprite.height, H)
            if cx1 > cx0 and cy1 > cy0:
                jobs.append((cx0, cy0, cx1, cy1, bx0, by0, sprite, img[cy0:cy1, cx0:cx1].copy()))
        for cx0, cy0, cx1, cy1, bx0, by0, sprite, base in jobs:
            if (cx0, cy0, cx1 - bx0, cy1 - by0) != (bx0, by0, sprite.width, sprite.height):
                sprite = sprite.crop((cx0 - bx0, cy0 - by0, cx1 - bx0, cy1 - by0))
            comp = Image.alpha_composite(Image.fromarray(base).convert("RGBA"), sprite)
            img[cy0:cy1, cx0:cx1] = np.asarray(comp.convert("RGB"))
        if bar is not None:
            # 1-px black frame (x0 - 1, y0 - 1) .. (x1, y1) inclusive, under the label boxes
            fx0, fy0, fx1, fy1 = x0 - 1, y0 - 1, x1, y1
            sx0, sy0, sx1, sy1 = max(fx0, 0), max(fy0, 0), min(fx1, W - 1), min(fy1, H - 1)
            if sx1 >= sx0 and sy1 >= sy0:
                rr = np.arange(sy0, sy1 + 1)[:, None]
                cc = np.arange(sx0, sx1 + 1)[None, :]
                mask = (rr == fy0) | (rr == fy1) | (cc == fx0) | (cc == fx1)
                for cx0, cy0, cx1, cy1, *_ in jobs:
                    mask &= ~((rr >= cy0) & (rr < cy1) & (cc >= cx0) & (cc < cx1))
                img[sy0:sy1 + 1, sx0:sx1 + 1][mask] = 0
            img[y0:y1, x0:x1] = grad8[:, None, :]   # keep the gradient exact
        return img


def annotate(image, text, xy=(4, 4), color=(0, 0, 0), size=None, box=True) -> np.ndarray:
    """Return a copy of ``image`` with ``text`` stamped at pixel ``xy`` (top-left by default).

    ``color`` is an RGB triple in 0..255; ``size`` the font height in pixels (default: about
    1/30 of the image height, at least 10); ``box`` draws a translucent white box behind the
    text for legibility.
    """
    from PIL import Image, ImageDraw, ImageFont

    img = _as_uint8_image(image)
    size = int(size) if size is not None else max(10, img.shape[0] // 30)
    try:
        font = ImageFont.load_default(size=size)
    except TypeError:  # Pillow < 10.1: fixed-size bitmap font
        font = ImageFont.load_default()
    # draw on a layer covering only the label (shifted by whole pixels: same glyphs) and
    # composite that crop; the rest of the image is untouched
    text = str(text)
    xy = tuple(xy)
    H, W = img.shape[:2]
    l, t, r, b = ImageDraw.Draw(Image.new("RGBA", (1, 1))).textbbox(xy, text, font=font)
    cx0, cy0 = max(int(math.floor(l)) - 3, 0), max(int(math.floor(t)) - 3, 0)
    cx1, cy1 = min(int(math.ceil(r)) + 4, W), min(int(math.ceil(b)) + 4, H)
    if not all(float(v).is_integer() for v in xy):   # fractional positions: no shifting
        cx0, cy0, cx1, cy1 = 0, 0, W, H
    out = np.array(img, copy=True)
    if cx1 <= cx0 or cy1 <= cy0:
        return out
    pil = Image.fromarray(img[cy0:cy1, cx0:cx1]).convert("RGBA")
    layer = Image.new("RGBA", pil.size, (0, 0, 0, 0))
    draw = ImageDraw.Draw(layer)
    sxy = (xy[0] - cx0, xy[1] - cy0)
    if box:
        draw.rectangle((l - 2 - cx0, t - 2 - cy0, r + 2 - cx0, b + 2 - cy0), fill=(255, 255, 255, 170))
    draw.text(sxy, text, font=font, fill=tuple(int(c) for c in color) + (255,))
    out[cy0:cy1, cx0:cx1] = np.asarray(Image.alpha_composite(pil, layer).convert("RGB"))
    return out
