"""bevy_rppm's rough metal as a Mitsuba 3 BSDF (`bevy_metal`), for references of the model
the renderer implements (`shaders/common/bsdf.wgsl`): GGX of α = roughness² with
height-correlated Smith visibility, Schlick's Fresnel from F0 (the base colour) to Bevy's F90,
plus Kulla and Conty's multiple-scattering lobe F0 (1 − E(μo)) (1 − E(μi)) / (π (1 − E_avg)),
which returns what single scattering loses (a white metal reflects all light, as Bevy's own
shading and issue 11's furnace test ask). Mitsuba's `roughconductor` is single scattering
with separable Smith and F = its reflectance at every angle: at roughness 0.5 it reflects
10–20 % less than this.

    import bevy_metal; bevy_metal.register()  # after mi.set_variant
    {"type": "bevy_metal", "roughness": 0.5, "base_color": {"type": "rgb", "value": [...]}}

`roughness` may be a texture (a metallic-roughness texture's G × factor, filtered as Bevy
filters it): the roughness is then read per point and α = roughness² is taken after the
filter, as Bevy's StandardMaterial does, with the multiple-scattering lobe interpolated
between ROWS roughnesses.
"""

import math

import numpy as np


def directional_albedo(roughness, mus, samples=4096, f0=1.0, f90=1.0):
    """E(μ) of the single-scattering lobe under Schlick's Fresnel from f0 to f90 (F = 1 by
    default), by the sampling `src/bsdf.rs` uses."""
    alpha = roughness * roughness
    k = np.arange(samples, dtype=np.uint64)
    # Hammersley: (k + 0.5)/n and the radical inverse of k.
    bits = np.zeros(samples, dtype=np.float64)
    kk, scale = k.copy(), 0.5
    for _ in range(32):
        bits += (kk & 1).astype(np.float64) * scale
        kk >>= np.uint64(1)
        scale *= 0.5
    u0, u1 = (k + 0.5) / samples, bits
    cos_h = np.sqrt((1 - u0) / (1 + (alpha * alpha - 1) * u0))
    sin_h = np.sqrt(np.maximum(1 - cos_h * cos_h, 0))
    phi = 2 * math.pi * u1
    out = []
    for mu in np.clip(mus, 1e-4, 1):
        v = np.array([math.sqrt(1 - mu * mu), 0.0, mu])
        v_dot_h = v[0] * sin_h * np.cos(phi) + v[2] * cos_h
        n_dot_l = 2 * v_dot_h * cos_h - v[2]
        ok = (n_dot_l > 0) & (v_dot_h > 0)
        nl = np.where(ok, n_dot_l, 1.0)
        g = 4 * smith_visibility(mu, nl, alpha) * mu * nl
        fresnel = f0 + (f90 - f0) * np.power(1 - np.clip(v_dot_h, 0, 1), 5)
        out.append(np.sum(np.where(ok, fresnel * g * v_dot_h / (mu * cos_h), 0.0)) / samples)
    return np.array(out)


def smith_visibility(n_dot_v, n_dot_l, a):
    a2 = a * a
    gv = n_dot_l * np.sqrt(n_dot_v * n_dot_v * (1 - a2) + a2)
    gl = n_dot_v * np.sqrt(n_dot_l * n_dot_l * (1 - a2) + a2)
    return 0.5 / np.maximum(gv + gl, 1e-8)


TABLE = 128
# Roughnesses 0, 1/(ROWS − 1), …, 1 of the tables of a textured roughness.
ROWS = 33


# GGX pieces on Dr.Jit arrays (local frame, n = z), shared with bevy_layers.py.

def ggx_terms(dr, mi, wi, wo, alpha):
    """(D(h), height-correlated Smith V, h) for wi and wo."""
    mu_i, mu_o = mi.Frame3f.cos_theta(wi), mi.Frame3f.cos_theta(wo)
    h = dr.normalize(wi + wo)
    n_dot_h = mi.Frame3f.cos_theta(h)
    a2 = alpha * alpha
    d = n_dot_h * n_dot_h * (a2 - 1) + 1
    gv = mu_o * dr.sqrt(mu_i * mu_i * (1 - a2) + a2)
    gl = mu_i * dr.sqrt(mu_o * mu_o * (1 - a2) + a2)
    return a2 / (math.pi * d * d), 0.5 / dr.maximum(gv + gl, 1e-8), h


def ggx_pdf(dr, mi, wi, wo, alpha):
    """The density of wo reflected about a normal drawn from D(h) cos θh."""
    d, _, h = ggx_terms(dr, mi, wi, wo, alpha)
    return d * mi.Frame3f.cos_theta(h) / (4 * dr.maximum(dr.dot(wo, h), 1e-8))


def ggx_reflect(dr, mi, wi, u, alpha):
    """wi reflected about a microfacet normal drawn from D(h) cos θh with u."""
    cos_h = dr.sqrt((1 - u.x) / (1 + (alpha * alpha - 1) * u.x))
    sin_h = dr.sqrt(dr.maximum(1 - cos_h * cos_h, 0))
    phi = 2 * math.pi * u.y
    h = mi.Vector3f(sin_h * dr.cos(phi), sin_h * dr.sin(phi), cos_h)
    return 2 * dr.dot(wi, h) * h - wi


def as_table(mi, values):
    """TABLE values as `table_at` reads them: a JIT array, or a list in the scalar variants
    (where `mi.Float` is Python's float, and `reference.py` falls back without an LLVM)."""
    if mi.variant().startswith("scalar"):
        return [float(v) for v in values]
    return mi.Float(values.astype("float32"))


def table_at(dr, mi, table, mu, row=0):
    """A table of TABLE values at cosines (k + ½)/TABLE, read linearly at mu; its `row`-th
    where `table` holds rows of TABLE values one after another (JIT arrays only)."""
    x = dr.clamp(mu * TABLE - 0.5, 0, TABLE - 1)
    if isinstance(table, list):
        i = min(int(x), TABLE - 2)
        return dr.lerp(table[i], table[i + 1], x - i)
    i = dr.minimum(mi.UInt32(x), TABLE - 2)
    f = x - mi.Float(i)
    k = row * TABLE + i
    return dr.lerp(dr.gather(mi.Float, table, k), dr.gather(mi.Float, table, k + 1), f)


def lost_tables(roughnesses):
    """1 − E(μ) at TABLE cosines and its cosine-weighted average, for each roughness."""
    mus = (np.arange(TABLE) + 0.5) / TABLE
    lost = np.array([np.clip(1 - directional_albedo(r, mus), 0, 1) for r in roughnesses])
    return lost, np.maximum(np.sum(2 * lost * mus, axis=1) / TABLE, 1e-3)


def register():
    import drjit as dr
    import mitsuba as mi

    class BevyMetal(mi.BSDF):
        def __init__(self, props):
            mi.BSDF.__init__(self, props)
            roughness = props.get("roughness", 0.5)
            self.textured = isinstance(roughness, mi.Texture)
            self.base = props.get("base_color", mi.ScalarColor3f(1.0))
            if not isinstance(self.base, mi.Texture):
                self.base = mi.load_dict({"type": "rgb", "value": self.base})
            if self.textured:
                if mi.variant().startswith("scalar"):
                    raise RuntimeError("bevy_metal: a textured roughness needs an llvm variant")
                self.roughness = roughness
                lost, avg = lost_tables(np.linspace(0.0, 1.0, ROWS))
                self.lost, self.lost_avg = mi.Float(lost.ravel().astype("float32")), mi.Float(avg.astype("float32"))
            else:
                self.roughness = float(roughness)
                self.alpha = self.roughness * self.roughness
                lost, avg = lost_tables([self.roughness])
                self.lost_avg = float(avg[0])
                self.lost = as_table(mi, lost[0])
            # Half the lobes by GGX, half by cosine: every direction either draws is sampled.
            self.m_flags = mi.BSDFFlags.GlossyReflection | mi.BSDFFlags.DiffuseReflection | mi.BSDFFlags.FrontSide
            self.m_components = [self.m_flags]

        def alpha_at(self, si, active):
            if not self.textured:
                return self.alpha
            r = dr.clamp(self.roughness.eval_1(si, active), 0.0, 1.0)
            return dr.maximum(r * r, 1e-3)

        def multiple_at(self, si, mu_i, mu_o, active):
            """(1 − E(μi)) (1 − E(μo)) / (π (1 − E_avg)) at the point's roughness."""
            if not self.textured:
                lost_i, lost_o = table_at(dr, mi, self.lost, mu_i), table_at(dr, mi, self.lost, mu_o)
                return lost_i * lost_o / (math.pi * self.lost_avg)
            x = dr.clamp(self.roughness.eval_1(si, active), 0.0, 1.0) * (ROWS - 1)
            row = dr.minimum(mi.UInt32(x), ROWS - 2)
            f = x - mi.Float(row)

            def value(r):
                lost_i, lost_o = table_at(dr, mi, self.lost, mu_i, r), table_at(dr, mi, self.lost, mu_o, r)
                return lost_i * lost_o / (math.pi * dr.gather(mi.Float, self.lost_avg, r))

            return dr.lerp(value(row), value(row + 1), f)

        def f_cos(self, si, wi, wo, active):
            """f·cos θo with wi toward the viewer, wo toward the light (local frame)."""
            mu_i, mu_o = mi.Frame3f.cos_theta(wi), mi.Frame3f.cos_theta(wo)
            active = active & (mu_i > 0) & (mu_o > 0)
            ggx_d, vis, h = ggx_terms(dr, mi, wi, wo, self.alpha_at(si, active))
            f0 = self.base.eval(si, active)
            f90 = dr.clamp(16.5 * (f0[0] + f0[1] + f0[2]), 0.0, 1.0)
            fc = dr.power(1 - dr.clamp(dr.dot(wi, h), 0, 1), 5)
            fresnel = f0 + (f90 - f0) * fc
            multiple = f0 * self.multiple_at(si, mu_i, mu_o, active)
            value = (fresnel * ggx_d * vis + multiple) * mu_o
            return dr.select(active, value, 0.0)

        def pdf_of(self, si, wi, wo, active):
            mu_i, mu_o = mi.Frame3f.cos_theta(wi), mi.Frame3f.cos_theta(wo)
            p = 0.5 * ggx_pdf(dr, mi, wi, wo, self.alpha_at(si, active)) + 0.5 * mu_o / math.pi
            return dr.select(active & (mu_i > 0) & (mu_o > 0), p, 0.0)

        def sample(self, ctx, si, sample1, sample2, active=True):
            wi = si.wi
            # GGX half vector (D cos θh) or a cosine direction.
            reflected = ggx_reflect(dr, mi, wi, sample2, self.alpha_at(si, active))
            cosine = mi.warp.square_to_cosine_hemisphere(sample2)
            wo = dr.select(sample1 < 0.5, reflected, cosine)
            bs = dr.zeros(mi.BSDFSample3f)
            bs.wo = wo
            bs.pdf = self.pdf_of(si, wi, wo, active)
            bs.eta = 1.0
            bs.sampled_type = mi.UInt32(+mi.BSDFFlags.GlossyReflection)
            bs.sampled_component = mi.UInt32(0)
            value = self.f_cos(si, wi, wo, active)
            ok = active & (bs.pdf > 0)
            return bs, dr.select(ok, value / dr.maximum(bs.pdf, 1e-12), 0.0)

        def eval(self, ctx, si, wo, active=True):
            return self.f_cos(si, si.wi, wo, active)

        def pdf(self, ctx, si, wo, active=True):
            return self.pdf_of(si, si.wi, wo, active)

        def eval_pdf(self, ctx, si, wo, active=True):
            return self.f_cos(si, si.wi, wo, active), self.pdf_of(si, si.wi, wo, active)

        def traverse(self, callback):
            pass

        def to_string(self):
            return f"BevyMetal[roughness={'texture' if self.textured else self.roughness}]"

    mi.register_bsdf("bevy_metal", lambda props: BevyMetal(props))
