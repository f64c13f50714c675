"""bevy_rppm's extra layers as Mitsuba 3 BSDFs, for references of the model the renderer
implements (`shaders/common/bsdf.wgsl`):

`bevy_coat`, the clearcoat: over any BSDF, a GGX lobe of α = roughness² (height-correlated
Smith) with Schlick's Fresnel from 0.04 to 1, times the coat's strength c, below roughness
0.02 a mirror; the BSDF under it sees (1 − c E(μi))(1 − c E(μo)) of the light, E(μ) being
what the lobe reflects from cosine μ. Single scattering, as Bevy's coat; what it loses
between the two passes is not given back.

`bevy_plastic`, the opaque dielectric: the coat above at strength 1 over Lambert, with
what the lobe loses by single scattering returned (F0 (1 − E(μi)) (1 − E(μo)) / (π (1 − E_avg)))
and the Lambertian reflectance remapped so that, averaged over directions, the two reflect
the base colour (`cosine_lobes` in bsdf.wgsl; `plastic_diffuse` gives the remapped colour).

`bevy_translucent`, diffuse transmission: Lambert of albedo ρ that reflects (1 − t) of what it
scatters and sends t through to the other side (Bevy's `diffuse_transmission` t), alike from
both sides.

    import bevy_layers; bevy_layers.register()  # after mi.set_variant
    {"type": "bevy_coat", "strength": 1.0, "roughness": 0.1, "bsdf": {"type": "diffuse", ...}}
    {"type": "bevy_plastic", "roughness": 0.3, "bsdf": {"type": "diffuse", "reflectance": plastic_diffuse(...)}}
    {"type": "bevy_translucent", "transmission": 0.5, "reflectance": {"type": "rgb", ...}}
"""

import math

import numpy as np

from bevy_metal import TABLE, as_table, directional_albedo, ggx_pdf, ggx_reflect, ggx_terms, lost_tables, table_at

DELTA_ROUGHNESS = 0.02
F0 = 0.04


def plastic_tables(roughness):
    """E(μ) of bsdf.wgsl's dielectric (the lobe at F0 from F0 to 1, plus F0 times what single
    scattering loses) at TABLE cosines, its cosine-weighted average, and 1 − E1(μ) with its
    average (E1 the lobe's at F = 1)."""
    mus = (np.arange(TABLE) + 0.5) / TABLE
    lost, lost_avg = lost_tables([roughness])
    energy = np.minimum(directional_albedo(roughness, mus, f0=F0) + F0 * lost[0], 1.0)
    return energy, min(np.sum(2 * energy * mus) / TABLE, 0.999), lost[0], lost_avg[0]


def plastic_diffuse(base, roughness):
    """The Lambertian colour under `bevy_plastic`: max(base − E_avg, 0) / (1 − E_avg) (the
    BSDF divides by 1 − E_avg once more, which would take a colour past 1)."""
    avg = plastic_tables(roughness)[1]
    return [max(c - avg, 0.0) / (1 - avg) for c in base]


def register():
    import drjit as dr
    import mitsuba as mi

    class BevyCoat(mi.BSDF):
        def __init__(self, props):
            mi.BSDF.__init__(self, props)
            self.strength = float(props.get("strength", 1.0))
            self.roughness = float(props.get("roughness", 0.0))
            self.alpha = self.roughness * self.roughness
            self.mirror = self.roughness < DELTA_ROUGHNESS
            self.base = props["bsdf"]
            mus = (np.arange(TABLE) + 0.5) / TABLE
            if self.mirror:
                albedo = F0 + (1 - F0) * np.power(1 - mus, 5)
            else:
                albedo = np.minimum(directional_albedo(self.roughness, mus, f0=F0), 1.0)
            self.albedo = as_table(mi, self.strength * albedo)
            lobe = mi.BSDFFlags.DeltaReflection if self.mirror else mi.BSDFFlags.GlossyReflection
            self.m_flags = self.base.flags() | lobe | mi.BSDFFlags.FrontSide
            self.m_components = [self.m_flags]

        def albedo_at(self, mu):
            if self.mirror:
                return self.strength * (F0 + (1 - F0) * dr.power(1 - dr.clamp(mu, 0, 1), 5))
            return table_at(dr, mi, self.albedo, mu)

        def lobe_cos(self, wi, wo):
            """The coat lobe's f·cos θo (0 for a mirror coat)."""
            if self.mirror:
                return mi.Float(0.0)
            mu_i, mu_o = mi.Frame3f.cos_theta(wi), mi.Frame3f.cos_theta(wo)
            ggx_d, vis, h = ggx_terms(dr, mi, wi, wo, self.alpha)
            fresnel = F0 + (1 - F0) * dr.power(1 - dr.clamp(dr.dot(wi, h), 0, 1), 5)
            value = self.strength * fresnel * ggx_d * vis * mu_o
            return dr.select((mu_i > 0) & (mu_o > 0), value, 0.0)

        def lobe_pdf(self, wi, wo):
            if self.mirror:
                return mi.Float(0.0)
            pdf = ggx_pdf(dr, mi, wi, wo, self.alpha)
            n_dot_h = mi.Frame3f.cos_theta(dr.normalize(wi + wo))
            return dr.select((mi.Frame3f.cos_theta(wo) > 0) & (n_dot_h > 0), pdf, 0.0)

        def through(self, wi, wo):
            return (1 - self.albedo_at(mi.Frame3f.cos_theta(wi))) * (1 - self.albedo_at(mi.Frame3f.cos_theta(wo)))

        def eval_pdf(self, ctx, si, wo, active=True):
            wi = si.wi
            base_value, base_pdf = self.base.eval_pdf(ctx, si, wo, active)
            p = self.albedo_at(mi.Frame3f.cos_theta(wi))
            value = base_value * self.through(wi, wo) + self.lobe_cos(wi, wo)
            pdf = (1 - p) * base_pdf + p * self.lobe_pdf(wi, wo)
            ok = active & (mi.Frame3f.cos_theta(wi) > 0)
            return dr.select(ok, value, 0.0), dr.select(ok, pdf, 0.0)

        def eval(self, ctx, si, wo, active=True):
            return self.eval_pdf(ctx, si, wo, active)[0]

        def pdf(self, ctx, si, wo, active=True):
            return self.eval_pdf(ctx, si, wo, active)[1]

        def sample(self, ctx, si, sample1, sample2, active=True):
            wi = si.wi
            active = active & (mi.Frame3f.cos_theta(wi) > 0)
            p = self.albedo_at(mi.Frame3f.cos_theta(wi))
            coat = sample1 < p
            # `~` of a scalar variant's Python bool is an int (~True == -2).
            base = (not coat) if isinstance(coat, bool) else ~coat
            # The base's own sample, with sample1 stretched back over 0..1.
            bs, base_weight = self.base.sample(ctx, si, dr.clamp((sample1 - p) / dr.maximum(1 - p, 1e-6), 0, 1),
                                               sample2, active & base)
            if self.mirror:
                wo = mi.Vector3f(-wi.x, -wi.y, wi.z)
                bs.wo = dr.select(coat, wo, bs.wo)
                bs.pdf = dr.select(coat, p, bs.pdf * (1 - p))
                bs.sampled_type = dr.select(coat, mi.UInt32(+mi.BSDFFlags.DeltaReflection), bs.sampled_type)
                bs.eta = dr.select(coat, 1.0, bs.eta)
                # Chosen with probability E(μi), the mirror keeps all; the base, what passes out.
                out = 1 - self.albedo_at(mi.Frame3f.cos_theta(bs.wo))
                weight = dr.select(coat, mi.Color3f(1.0), base_weight * out)
                return bs, dr.select(active & (bs.pdf > 0), weight, 0.0)
            reflected = ggx_reflect(dr, mi, wi, sample2, self.alpha)
            base_delta = mi.has_flag(bs.sampled_type, mi.BSDFFlags.Delta) & base
            bs.wo = dr.select(coat, reflected, bs.wo)
            bs.eta = dr.select(coat, 1.0, bs.eta)
            bs.sampled_type = dr.select(coat, mi.UInt32(+mi.BSDFFlags.GlossyReflection), bs.sampled_type)
            value, pdf = self.eval_pdf(ctx, si, bs.wo, active)
            weight = value / dr.maximum(pdf, 1e-12)
            # A delta sample of the base has no density to mix: its own weight, through the coat.
            weight = dr.select(base_delta, base_weight * (1 - self.albedo_at(mi.Frame3f.cos_theta(bs.wo))), weight)
            bs.pdf = dr.select(base_delta, bs.pdf * (1 - p), pdf)
            return bs, dr.select(active & (bs.pdf > 0), weight, 0.0)

        def traverse(self, callback):
            pass

        def to_string(self):
            return f"BevyCoat[strength={self.strength}, roughness={self.roughness}, base={self.base}]"

    mi.register_bsdf("bevy_coat", lambda props: BevyCoat(props))

    class BevyPlastic(BevyCoat):
        def __init__(self, props):
            BevyCoat.__init__(self, props)
            energy, self.energy_avg, lost, lost_avg = plastic_tables(self.roughness)
            self.albedo = as_table(mi, energy)
            self.lost = as_table(mi, lost)
            self.lost_avg = float(lost_avg)

        def through(self, wi, wo):
            return BevyCoat.through(self, wi, wo) / (1 - self.energy_avg)

        def eval_pdf(self, ctx, si, wo, active=True):
            value, pdf = BevyCoat.eval_pdf(self, ctx, si, wo, active)
            mu_i, mu_o = mi.Frame3f.cos_theta(si.wi), mi.Frame3f.cos_theta(wo)
            multiple = F0 * table_at(dr, mi, self.lost, mu_i) * table_at(dr, mi, self.lost, mu_o) / (
                math.pi * self.lost_avg) * mu_o
            ok = active & (mu_i > 0) & (mu_o > 0)
            return value + dr.select(ok, multiple, 0.0), pdf

        def to_string(self):
            return f"BevyPlastic[roughness={self.roughness}, base={self.base}]"

    mi.register_bsdf("bevy_plastic", lambda props: BevyPlastic(props))

    class BevyTranslucent(mi.BSDF):
        def __init__(self, props):
            mi.BSDF.__init__(self, props)
            self.transmission = float(props.get("transmission", 0.0))
            self.albedo = props.get("reflectance", mi.ScalarColor3f(0.5))
            if not isinstance(self.albedo, mi.Texture):
                self.albedo = mi.load_dict({"type": "rgb", "value": self.albedo})
            self.m_flags = (mi.BSDFFlags.DiffuseReflection | mi.BSDFFlags.DiffuseTransmission
                            | mi.BSDFFlags.FrontSide | mi.BSDFFlags.BackSide)
            self.m_components = [self.m_flags]

        def share(self, wi, wo):
            """The lobe's share toward wo: 1 − t on wi's side, t through."""
            same = mi.Frame3f.cos_theta(wi) * mi.Frame3f.cos_theta(wo) > 0
            return dr.select(same, 1 - self.transmission, self.transmission)

        def eval_pdf(self, ctx, si, wo, active=True):
            density = self.share(si.wi, wo) * dr.abs(mi.Frame3f.cos_theta(wo)) / math.pi
            return self.albedo.eval(si, active) * density, density

        def eval(self, ctx, si, wo, active=True):
            return self.eval_pdf(ctx, si, wo, active)[0]

        def pdf(self, ctx, si, wo, active=True):
            return self.eval_pdf(ctx, si, wo, active)[1]

        def sample(self, ctx, si, sample1, sample2, active=True):
            wo = mi.warp.square_to_cosine_hemisphere(sample2)
            # On wi's side, or through with probability t.
            side = dr.select(mi.Frame3f.cos_theta(si.wi) >= 0, 1.0, -1.0)
            side = dr.select(sample1 < self.transmission, -side, side)
            wo = mi.Vector3f(wo.x, wo.y, wo.z * side)
            bs = dr.zeros(mi.BSDFSample3f)
            bs.wo = wo
            bs.pdf = self.pdf(ctx, si, wo, active)
            bs.eta = 1.0
            through = mi.Frame3f.cos_theta(si.wi) * wo.z < 0
            bs.sampled_type = dr.select(through, mi.UInt32(+mi.BSDFFlags.DiffuseTransmission),
                                        mi.UInt32(+mi.BSDFFlags.DiffuseReflection))
            bs.sampled_component = mi.UInt32(0)
            return bs, dr.select(active & (bs.pdf > 0), self.albedo.eval(si, active), 0.0)

        def traverse(self, callback):
            pass

        def to_string(self):
            return f"BevyTranslucent[transmission={self.transmission}]"

    mi.register_bsdf("bevy_translucent", lambda props: BevyTranslucent(props))
