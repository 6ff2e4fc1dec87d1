"""Periodic colour textures and their filtered (mip-mapped) look-up at world positions.

A texture is an RGB albedo image that tiles the plane seamlessly; a surface point with
texture coordinates ``(s, t)`` metres reads the texel ``(s, t) / texel_m``. Far or
grazing surfaces cover many texels per pixel, so the look-up blends the two pyramid levels
whose texel size brackets the pixel footprint (trilinear filtering): both cameras then see
the same, alias-free surface, which keeps the ground truth photometrically consistent.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

_REMAP_WIDTH = 1024
"""Flat sample lists are folded into rows of this width for :func:`cv2.remap` (< 32767)."""


def periodic_noise(rng: np.random.Generator, size: int, wavelength_texels: float) -> np.ndarray:
    """Seamless band-pass noise ``(size, size)`` float32, zero mean, unit standard deviation.

    White noise filtered in the Fourier domain by a Gaussian ring around the spatial
    frequency ``1 / wavelength_texels``; being built from the FFT, it tiles without seams.
    """
    white = rng.standard_normal((size, size))
    f = np.fft.fftfreq(size)
    radius = np.hypot(f[:, None], f[None, :])
    centre = 1.0 / wavelength_texels
    gain = np.exp(-0.5 * ((radius - centre) / (0.5 * centre)) ** 2)
    gain[0, 0] = 0.0
    noise = np.real(np.fft.ifft2(np.fft.fft2(white) * gain))
    return ((noise - noise.mean()) / max(float(noise.std()), 1e-12)).astype(np.float32)


def _halve(image: np.ndarray) -> np.ndarray:
    h, w = image.shape[:2]
    return image.reshape(h // 2, 2, w // 2, 2, -1).mean(axis=(1, 3)).astype(np.float32)


@dataclass(frozen=True, eq=False)
class MipTexture:
    """A tiling RGB albedo texture with its pyramid, ``texel_m`` metres per finest texel.

    Attributes
    ----------
    levels : tuple of numpy.ndarray
        ``float32 (S / 2**k, S / 2**k, 3)`` albedo in [0, 1], finest first.
    texel_m : float
        Size of one texel of level 0 in metres.
    """

    levels: tuple[np.ndarray, ...]
    texel_m: float

    @classmethod
    def from_image(cls, image: np.ndarray, texel_m: float, *, max_levels: int = 32) -> MipTexture:
        """Build the pyramid of a square power-of-two texture by exact 2x2 averaging.

        ``max_levels=1`` keeps only the finest level: plain bilinear look-up, for textures
        so smooth that no footprint in the scene spans a texel.
        """
        levels = [np.ascontiguousarray(image, dtype=np.float32)]
        while len(levels) < max_levels and levels[-1].shape[0] > 1 and levels[-1].shape[0] % 2 == 0:
            levels.append(_halve(levels[-1]))
        return cls(tuple(levels), float(texel_m))

    def sample(self, s_m: np.ndarray, t_m: np.ndarray, footprint_m: np.ndarray) -> np.ndarray:
        """Albedo ``(N, 3)`` at texture coordinates ``(s, t)`` metres with pixel footprints in metres."""
        n = s_m.size
        out = np.empty((n, 3), dtype=np.float32)
        if n == 0:
            return out
        top = len(self.levels) - 1
        if top == 0:
            return self._lookup(0, s_m, t_m)
        level = np.log2(np.maximum(np.asarray(footprint_m, np.float32) / np.float32(self.texel_m), 1e-6))
        np.clip(level, 0.0, top, out=level)
        base = np.minimum(level.astype(np.int8), max(top - 1, 0))
        # Sort once by pyramid level so that each level works on a contiguous slice.
        order = np.argsort(base, kind="stable")
        counts = np.bincount(base, minlength=top + 1)
        s_sorted, t_sorted = s_m[order], t_m[order]
        frac = (level - base)[order][:, None]
        result = np.empty((n, 3), dtype=np.float32)
        start = 0
        for k, count in enumerate(counts):
            if count == 0:
                continue
            part = slice(start, start + count)
            lo = self._lookup(k, s_sorted[part], t_sorted[part])
            if top > 0:
                hi = self._lookup(k + 1, s_sorted[part], t_sorted[part])
                lo += (hi - lo) * frac[part]
            result[part] = lo
            start += count
        out[order] = result
        return out

    def _lookup(self, k: int, s_m: np.ndarray, t_m: np.ndarray) -> np.ndarray:
        tex = self.levels[k]
        size = tex.shape[0]
        scale = 1.0 / (self.texel_m * 2 ** k)
        n = s_m.size
        rows = -(-n // _REMAP_WIDTH)
        maps = np.zeros((2, rows * _REMAP_WIDTH), dtype=np.float32)
        # Texel centres are at integer coordinates, hence the half-texel shift; wrapping
        # here keeps the coordinates inside the range OpenCV's fixed-point maps can hold.
        np.multiply(s_m, scale, out=maps[0, :n], casting="unsafe")
        np.multiply(t_m, scale, out=maps[1, :n], casting="unsafe")
        maps[:, :n] -= 0.5
        np.mod(maps, size, out=maps)
        got = cv2.remap(tex, maps[0].reshape(rows, _REMAP_WIDTH), maps[1].reshape(rows, _REMAP_WIDTH),
                        interpolation=cv2.INTER_LINEAR, borderMode=cv2.BORDER_WRAP)
        return got.reshape(-1, 3)[:n]
