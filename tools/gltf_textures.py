"""glTF textures as Mitsuba 3 `bitmap`s for tools/reference.py: each texture's pixels with its
factor baked in, written as a linear EXR and wrapped, filtered and transformed as its glTF
sampler and KHR_texture_transform say (numpy needed)."""

import math
import os
import sys

from gltf_read import image_bytes


class Textures:
    """glTF textures as linear EXRs for Mitsuba's `bitmap` (factor baked in), made with numpy."""

    def __init__(self, gltf, buffers, folder, tmp):
        self.gltf, self.buffers, self.folder, self.tmp = gltf, buffers, folder, tmp

    def _pixels(self, info):
        import mitsuba as mi
        import numpy as np

        image = self.gltf["images"][self.gltf["textures"][info["index"]]["source"]]
        encoded = os.path.join(self.tmp, f"image_{len(os.listdir(self.tmp))}")
        with open(encoded, "wb") as f:
            f.write(image_bytes(self.gltf, self.buffers, self.folder, image))
        raw = np.array(mi.Bitmap(encoded))
        # 8- or 16-bit integers (PNG, JPEG) to [0, 1]; floats as they are.
        scale = float(np.iinfo(raw.dtype).max) if np.issubdtype(raw.dtype, np.integer) else 1.0
        pixels = raw.astype(np.float32) / scale
        if pixels.ndim == 2:
            pixels = pixels[..., None]
        if pixels.shape[2] < 3:
            pixels = np.concatenate([pixels[..., :1]] * 3 + [pixels[..., 1:]], axis=2)
        return pixels

    def sampler(self, info):
        """The texture's glTF sampler as Mitsuba's `wrap_mode` and `filter_type` (one wrap for
        both axes in Mitsuba: u's where they differ; the magnification filter)."""
        index = self.gltf["textures"][info["index"]].get("sampler")
        s = self.gltf.get("samplers", [])[index] if index is not None else {}
        wraps = {10497: "repeat", 33071: "clamp", 33648: "mirror"}
        wrap_s, wrap_t = (wraps[s.get(k, 10497)] for k in ("wrapS", "wrapT"))
        if wrap_s != wrap_t:
            print(f"reference.py: wrapS {wrap_s} and wrapT {wrap_t} differ; both {wrap_s}", file=sys.stderr)
        return {"wrap_mode": wrap_s, "filter_type": "nearest" if s.get("magFilter") == 9728 else "bilinear"}

    def _write(self, array, name, info=None):
        import mitsuba as mi
        import numpy as np

        path = os.path.join(self.tmp, f"{name}_{len(os.listdir(self.tmp))}.exr")
        mi.Bitmap(np.ascontiguousarray(array, dtype=np.float32)).write(path)
        texture = {"type": "bitmap", "filename": path, "raw": True, "filter_type": "bilinear", "wrap_mode": "repeat"}
        if info is not None:
            texture.update(self.sampler(info))
            transform = info.get("extensions", {}).get("KHR_texture_transform")
            if transform:
                texture["to_uv"] = self.uv_transform(transform)
        return texture

    @staticmethod
    def uv_transform(t):
        """KHR_texture_transform's matrix, offset · rotation · scale, as Mitsuba's `to_uv`."""
        import mitsuba as mi

        if "texCoord" in t:
            print("reference.py: KHR_texture_transform's texCoord is ignored", file=sys.stderr)
        (ox, oy), r, (sx, sy) = t.get("offset", [0, 0]), t.get("rotation", 0.0), t.get("scale", [1, 1])
        c, s = math.cos(r), math.sin(r)
        return mi.ScalarTransform3f([[c * sx, s * sy, ox], [-s * sx, c * sy, oy], [0, 0, 1]])

    def _linear(self, info, factor):
        """An sRGB colour texture's pixels in linear values, times a linear factor."""
        import numpy as np

        c = self._pixels(info)[..., :3]
        linear = np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
        return linear * np.array(factor[:3], dtype=np.float32)

    def colour(self, info, factor):
        """An sRGB colour texture times a linear factor."""
        return self._write(self._linear(info, factor), "colour", info)

    def plastic_colour(self, info, factor, avg):
        """The Lambertian colour under `bevy_plastic` of a textured base colour (tools/bevy_layers.py
        `plastic_diffuse`): max(base − E_avg, 0) / (1 − E_avg) of the base colour as filtering gives
        it, as bevy_rppm takes it. Per texel, Mitsuba's bilinear filter would blend the kinked values
        instead: between a texel under E_avg and one over it (a checker of 0.04 and 0.43 at
        roughness 0.39) the edge pixels read up to 20 % brighter than bevy_rppm's, 1.4 % of a
        random room's light. So a bilinearly filtered texture is first upsampled
        (`upsampled`), bilinearly, where the max is taken."""
        import numpy as np

        base = self._linear(info, factor)
        sampler = self.sampler(info)
        if sampler["filter_type"] == "bilinear":
            base = upsampled(base, sampler["wrap_mode"] == "repeat")
        return self._write(np.maximum(base - avg, 0.0) / (1.0 - avg), f"plastic{avg:.4f}", info)

    def metallic_roughness(self, info, metallic, roughness):
        """Metallic (B × factor) as a blend weight, the roughness (G × factor) and GGX
        α = (G × factor)² as bitmaps."""
        import numpy as np

        p = self._pixels(info)
        metal = p[..., 2] * metallic
        rough = p[..., 1] * roughness
        alpha = np.maximum(rough ** 2, 1e-3)
        return tuple(self._write(np.stack([x] * 3, axis=2), name, info)
                     for x, name in ((metal, "metallic"), (rough, "roughness"), (alpha, "alpha")))

    def normal_map(self, info, opposite=True):
        """A glTF normal map for Mitsuba's `normalmap`: its frame's second axis is n × ∂p/∂u,
        glTF's is −∂p/∂v (texture +Y up, v down the image); where the two are `opposite` (UVs
        whose (∂p/∂u, ∂p/∂v, n) turn right-handed), green is flipped."""
        p = self._pixels(info)[..., :3].copy()
        if opposite:
            p[..., 1] = 1.0 - p[..., 1]
        return self._write(p, "normal" if opposite else "normal_kept", info)

    def spot_falloff(self, inner, outer, size=1024):
        """Bevy's spot falloff, the square of a ramp in cos θ from the outer cone to the inner,
        as the texture Mitsuba's `spot` projects over its cone: texel (u, v) is the direction
        (2u − 1, 2v − 1)·tan(outer) off the axis (Mitsuba's `direction_to_uv`)."""
        import numpy as np

        t = (2.0 * (np.arange(size) + 0.5) / size - 1.0) * math.tan(outer)
        cos = 1.0 / np.sqrt(1.0 + t[None, :] ** 2 + t[:, None] ** 2)
        if math.cos(inner) > math.cos(outer):
            ramp = np.clip((cos - math.cos(outer)) / (math.cos(inner) - math.cos(outer)), 0.0, 1.0) ** 2
        else:
            ramp = (cos >= math.cos(outer)).astype(np.float32)
        texture = self._write(np.stack([ramp] * 3, axis=2), "spot")
        texture["wrap_mode"] = "clamp"
        return texture

    def alpha(self, info, alpha_factor):
        """Opacity of blended alpha: the texture's alpha (1 without one) times the factor."""
        import numpy as np

        p = self._pixels(info)
        alpha = (p[..., 3] if p.shape[2] > 3 else np.ones(p.shape[:2], np.float32)) * alpha_factor
        return self._write(np.stack([alpha] * 3, axis=2), "alpha", info)

    def mask(self, info, alpha_factor, cutoff):
        """Opacity of an alpha cut-out: alpha upsampled 4× bilinearly, then thresholded (as
        rppm thresholds its bilinear alpha)."""
        import numpy as np

        p = self._pixels(info)
        alpha = (p[..., 3] if p.shape[2] > 3 else np.ones(p.shape[:2], np.float32)) * alpha_factor
        h, w = alpha.shape
        ys = (np.arange(4 * h) + 0.5) / 4 - 0.5
        xs = (np.arange(4 * w) + 0.5) / 4 - 0.5
        y0, x0 = np.floor(ys).astype(int), np.floor(xs).astype(int)
        fy, fx = (ys - y0)[:, None], (xs - x0)[None, :]
        a = lambda dy, dx: alpha[(y0 + dy) % h][:, (x0 + dx) % w]
        up = (a(0, 0) * (1 - fx) + a(0, 1) * fx) * (1 - fy) + (a(1, 0) * (1 - fx) + a(1, 1) * fx) * fy
        opacity = (up >= cutoff).astype(np.float32)
        return self._write(np.stack([opacity] * 3, axis=2), "mask", info)


def upsampled(pixels, repeat, most=2048, factor=8):
    """`pixels` (H × W × C) bilinearly upsampled `factor` times (fewer where a side would pass
    `most`), texel centres as a bilinear lookup places them: what Mitsuba's bilinear filter of
    the result gives is that of the original, and a function of it taken per new texel follows
    the filtered values within 1/factor of a texel. Edges repeat or clamp."""
    import numpy as np

    k = max(1, min(factor, most // max(pixels.shape[0], pixels.shape[1])))
    if k == 1:
        return pixels
    for axis in (0, 1):
        n = pixels.shape[axis]
        x = (np.arange(n * k) + 0.5) / k - 0.5
        i = np.floor(x).astype(int)
        t = (x - i).astype(np.float32)
        lo, hi = (np.mod(i, n), np.mod(i + 1, n)) if repeat else (np.clip(i, 0, n - 1), np.clip(i + 1, 0, n - 1))
        shape = [1, 1, 1]
        shape[axis] = n * k
        t = t.reshape(shape)
        pixels = np.take(pixels, lo, axis=axis) * (1 - t) + np.take(pixels, hi, axis=axis) * t
    return pixels

