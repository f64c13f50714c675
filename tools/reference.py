#!/usr/bin/env python3
"""Ground truth for bevy_rppm: renders a glTF scene with Mitsuba 3's path tracer under the
conventions of shared/docs/CONVENTIONS.md (linear radiance, box filter, photometric numbers
used as radiometric ones, light range ignored).

    python3 tools/reference.py SCENE.gltf --out REF.exr [--width 256] [--height 256]
                               [--spp 1024] [--variant llvm_ad_rgb|scalar_rgb] [--metal bevy|mitsuba]
                               [--integrator path|ptracer] [--json REF.json]

Needs `pip install mitsuba numpy` (Mitsuba 3.9; numpy only for textured scenes). The llvm
variants need an LLVM that drjit accepts: on Debian 12 install `libllvm19` and the script
points DRJIT_LIBLLVM_PATH at it; otherwise it falls back to `scalar_rgb`, which is slower.

Material mapping (as the references in shared/scenes): metallic 0 and no transmission →
Lambertian `diffuse` at roughness 1 or below 0.02 (Bevy's 4% specular layer is left out, see
CONVENTIONS.md), else `bevy_plastic` (tools/bevy_layers.py: bevy_rppm's dielectric,
that layer over an albedo-keeping diffuse lobe, per texel under a base colour texture; it leaves
out bevy_rppm's dimming of the layer on dark surfaces from roughness 0.75, `matte_share`); partial metallic → a `blendbsdf` of the two; metallic with
roughness < 0.02 → perfect `conductor`; metallic otherwise → `bevy_metal` (tools/bevy_metal.py:
bevy_rppm's GGX with multiple scattering and Schlick's Fresnel; `--metal mitsuba` gives
Mitsuba's single-scattering `roughconductor`, α = roughness², instead); transmission with roughness < 0.02 → `dielectric`, rougher → `roughdielectric` (GGX, α =
roughness²); inside either an absorbing `homogeneous` medium
(and the `volpath` integrator) for `KHR_materials_volume` with a thickness; emissive → area
emitter; `KHR_materials_clearcoat` → `bevy_coat` (tools/bevy_layers.py: bevy_rppm's coat over
the BSDF above; its textures and normal are left out); `KHR_materials_diffuse_transmission` →
`bevy_translucent` (bevy_layers.py: Lambert reflecting 1 − t, transmitting t, both sides; its colour and
textures are left out, as in bevy_rppm). `KHR_materials_specular` tints only the
dielectric's specular layer, which the Lambertian stand-in leaves out.
Textures (numpy needed): base colour texture × factor (a metal's reflectance too) and emissive texture × factor as
bitmaps wrapped and filtered as their glTF sampler says (Mitsuba has one wrap mode for both
axes; the magnification filter), COLOR_0 (× the base colour factor) as the `vertex_color` mesh attribute (under a base colour
texture, folded into its factor where all alike, else left out), alpha `MASK` as a
`mask` BSDF (opacity 0 or 1), alpha `BLEND` as a `mask` of opacity alpha (texture × factor), `doubleSided` as `twosided`, a metallic-roughness texture (on a Lambertian
base) as a `blendbsdf` of Lambert and the rough metal weighted by metallic, the metal at the
roughness filtered at each point as Bevy filters it (`bevy_metal` reads the texture; an llvm
variant), a normal texture
as `normalmap` (its folding of normals that face away from the viewer and its terminator
term, on by default since Mitsuba 3.7.1, turned off: Bevy has neither);
KHR_texture_transform as the bitmap's `to_uv` (its texCoord is left out), the normal map's
scale is left out.
Lights: KHR_lights_punctual point (W/sr = cd; with `extras.rppm_radius` a sphere of that
radius, radiance I/(πr²), that neither blocks nor reflects), spot (Bevy's falloff, the square of a ramp in
cos θ from the outer cone to the inner, as a texture the spot projects), directional (W/m² = lux); their
colour is read as sRGB, as Bevy's glTF loader reads it.
"""

import argparse
import glob
import json
import math
import os
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from gltf_read import accessor, load, srgb_to_linear, transform_dir, transform_normal, transform_point, walk, write_ply  # noqa: E402
from gltf_textures import Textures  # noqa: E402

def green_opposite(positions, faces, uvs):
    """Whether Mitsuba's second tangent axis (n × ∂p/∂u) is opposite to glTF's (−∂p/∂v) on
    this primitive, read off its first triangle whose UVs span an area."""
    for a, b, c in faces:
        e1, e2 = [positions[b][i] - positions[a][i] for i in range(3)], [positions[c][i] - positions[a][i] for i in range(3)]
        d1, d2 = [uvs[b][i] - uvs[a][i] for i in range(2)], [uvs[c][i] - uvs[a][i] for i in range(2)]
        r = d1[0] * d2[1] - d1[1] * d2[0]
        if abs(r) < 1e-12:
            continue
        dpdu = [(e1[i] * d2[1] - e2[i] * d1[1]) / r for i in range(3)]
        dpdv = [(e2[i] * d1[0] - e1[i] * d2[0]) / r for i in range(3)]
        n = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]]
        t = [n[1] * dpdu[2] - n[2] * dpdu[1], n[2] * dpdu[0] - n[0] * dpdu[2], n[0] * dpdu[1] - n[1] * dpdu[0]]
        return sum(t[i] * -dpdv[i] for i in range(3)) < 0
    return True


def with_normal_map(material, textures, bsdf, description, opposite=True):
    """The BSDF under the material's normal texture, bent as Bevy bends it: Mitsuba's folding
    of normals that face away from the viewer and its terminator term (on by default since
    3.7.1) off, as Bevy has neither."""
    if "normalTexture" not in material or not textures:
        return bsdf, description
    return ({"type": "normalmap", "normalmap": textures.normal_map(material["normalTexture"], opposite), "bsdf": bsdf,
             "flip_invalid_normals": False, "use_shadowing_function": False}, f"normalmap({description})")


def bsdf_of(material, textures=None, vertex_colors=False, opposite=True):
    """Mitsuba BSDF dict and a one-line description, per the mapping in this file's header;
    `opposite` as `green_opposite` says of the primitive."""
    pbr = material.get("pbrMetallicRoughness", {})
    base = pbr.get("baseColorFactor", [1, 1, 1, 1])[:3]
    metallic = pbr.get("metallicFactor", 1.0)
    roughness = pbr.get("roughnessFactor", 1.0)
    ext = material.get("extensions", {})
    transmission = ext.get("KHR_materials_transmission", {}).get("transmissionFactor", 0.0)
    ior = ext.get("KHR_materials_ior", {}).get("ior", 1.5)
    rgb = {"type": "rgb", "value": base}
    glass = transmission * (1.0 - metallic)
    if glass > 0:
        if roughness < 0.02:
            bsdf, description = {"type": "dielectric", "int_ior": ior, "ext_ior": 1.0}, f"dielectric(ior={ior})"
        else:
            alpha = roughness * roughness
            bsdf = {"type": "roughdielectric", "distribution": "ggx", "alpha": alpha, "int_ior": ior, "ext_ior": 1.0}
            description = f"roughdielectric(ior={ior}, alpha={alpha:.3f})"
        if glass < 1:
            # Bevy's specular transmission t: the surface is t glass and 1 − t the opaque
            # material without it.
            rest = dict(material, extensions={k: v for k, v in ext.items() if k != "KHR_materials_transmission"})
            opaque, kind = bsdf_of(rest, textures, vertex_colors, opposite)
            bsdf = {"type": "blendbsdf", "weight": glass, "bsdf_0": opaque, "bsdf_1": bsdf}
            return bsdf, f"blend({kind}, {description}) by transmission {glass}"
        return with_normal_map(material, textures, bsdf, description, opposite)
    textured_metal = "metallicRoughnessTexture" in pbr and textures
    if 0 < metallic < 1 and not textured_metal:
        # glTF's metallic mixes the dielectric and the metal linearly (bevy_rppm too).
        rest = dict(material, pbrMetallicRoughness=dict(pbr, metallicFactor=0.0))
        dielectric, kind = bsdf_of(rest, textures, vertex_colors, opposite)
        metal, metal_kind = bsdf_of(dict(material, pbrMetallicRoughness=dict(pbr, metallicFactor=1.0)), textures,
                                     opposite=opposite)
        return ({"type": "blendbsdf", "weight": metallic, "bsdf_0": dielectric, "bsdf_1": metal},
                f"blend({kind}, {metal_kind}) by metallic {metallic}")
    # A metal's base colour texture tints its reflection.
    metal_rgb = textures.colour(pbr["baseColorTexture"], base) if "baseColorTexture" in pbr and textures else rgb
    if metallic > 0 and roughness < 0.02 and not textured_metal:
        return with_normal_map(material, textures, {"type": "conductor", "material": "none",
                                                    "specular_reflectance": metal_rgb}, "conductor(none)", opposite)
    if metallic > 0 and not textured_metal:
        return with_normal_map(material, textures, *rough_metal(metal_rgb, None, roughness), opposite)
    description = "diffuse(lambert)"
    if "baseColorTexture" in pbr and textures:
        rgb = textures.colour(pbr["baseColorTexture"], base)
        description += " x base colour texture"
        if vertex_colors:
            print("reference.py: vertex colours under a base colour texture are ignored", file=sys.stderr)
    elif vertex_colors:
        rgb = {"type": "mesh_attribute", "name": "vertex_color"}
        description += " x vertex colours"
    bsdf = {"type": "diffuse", "reflectance": rgb}
    translucent = ext.get("KHR_materials_diffuse_transmission", {}).get("diffuseTransmissionFactor", 0.0)
    if 0.02 <= roughness < 1 and metallic == 0 and rgb["type"] == "rgb" and not translucent > 0 \
            and not textured_metal:
        # A dielectric smoother than the convention's Lambertian one (roughness 1): bevy_rppm's
        # own, Bevy's 4 % GGX lobe over a diffuse lobe that keeps the base colour's albedo.
        from bevy_layers import plastic_diffuse

        bsdf = {"type": "bevy_plastic", "roughness": roughness,
                "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": plastic_diffuse(base, roughness)}}}
        description = f"bevy_plastic(roughness={roughness})"
    elif 0.02 <= roughness < 1 and metallic == 0 and "baseColorTexture" in pbr and textures \
            and not translucent > 0 and not textured_metal:
        # The same over a base colour texture, its Lambertian colour per texel.
        from bevy_layers import plastic_tables

        avg = plastic_tables(roughness)[1]
        bsdf = {"type": "bevy_plastic", "roughness": roughness,
                "bsdf": {"type": "diffuse", "reflectance": textures.plastic_colour(pbr["baseColorTexture"], base, avg)}}
        description = f"bevy_plastic(roughness={roughness}) x base colour texture"
    if translucent > 0:
        # Two-sided by itself: `twosided` below would hide what passes through.
        bsdf = {"type": "bevy_translucent", "transmission": translucent, "reflectance": rgb}
        description = f"bevy_translucent({description}, transmission={translucent})"
    if textured_metal:
        # Per point: Lambert where metallic is 0, the rough metal where 1, at the filtered roughness.
        metal, rough, alpha = textures.metallic_roughness(pbr["metallicRoughnessTexture"], metallic, roughness)
        conductor, kind = rough_metal(rgb, alpha, rough)
        bsdf = {"type": "blendbsdf", "weight": metal, "bsdf_0": bsdf, "bsdf_1": conductor}
        description = f"blend({description}, {kind}) by metallic texture"
    bsdf, description = with_normal_map(material, textures, bsdf, description, opposite)
    coat = material.get("extensions", {}).get("KHR_materials_clearcoat", {})
    if coat.get("clearcoatFactor", 0.0) > 0:
        strength, rough = coat["clearcoatFactor"], coat.get("clearcoatRoughnessFactor", 0.0)
        bsdf = {"type": "bevy_coat", "strength": strength, "roughness": rough, "bsdf": bsdf}
        description = f"bevy_coat({description}, strength={strength}, roughness={rough})"
    if "KHR_materials_specular" in material.get("extensions", {}):
        print("reference.py: KHR_materials_specular tints the dielectric's specular layer, which Lambert "
              "leaves out", file=sys.stderr)
    if material.get("doubleSided") and not translucent > 0:
        bsdf = {"type": "twosided", "bsdf": bsdf}
        description = f"twosided({description})"
    mode, alpha = material.get("alphaMode", "OPAQUE"), pbr.get("baseColorFactor", [1, 1, 1, 1])[3]
    opacity = None
    if mode == "MASK" and textures and "baseColorTexture" in pbr:
        opacity = textures.mask(pbr["baseColorTexture"], alpha, material.get("alphaCutoff", 0.5))
    elif mode == "MASK" and alpha < material.get("alphaCutoff", 0.5):
        opacity = 0.0
    elif mode == "BLEND" and textures and "baseColorTexture" in pbr:
        opacity = textures.alpha(pbr["baseColorTexture"], alpha)
    elif mode == "BLEND" and alpha < 1.0:
        opacity = alpha
    if opacity is not None:
        # Bevy composites a blended surface over what lies behind by its alpha (bevy_rppm
        # draws the surface or goes through it by alpha): Mitsuba's `mask` does the same.
        bsdf = {"type": "mask", "opacity": opacity, "bsdf": bsdf}
        description = f"mask({description})"
    return bsdf, description


METAL = "bevy"


def rough_metal(rgb, alpha_texture, roughness):
    """A rough conductor: bevy_rppm's (`bevy_metal`: multiple scattering, Schlick's Fresnel)
    or, with `--metal mitsuba`, Mitsuba's `roughconductor` (single scattering, F constant);
    where the roughness is textured, `roughness` is its texture and `alpha_texture` its α
    (Mitsuba's filters α, Bevy the roughness)."""
    if METAL == "bevy":
        shown = "texture" if isinstance(roughness, dict) else f"{roughness:.3f}"
        return ({"type": "bevy_metal", "roughness": roughness, "base_color": rgb}, f"bevy_metal(roughness={shown})")
    alpha = alpha_texture if alpha_texture is not None else max(roughness * roughness, 1e-3)
    return ({"type": "roughconductor", "material": "none", "distribution": "ggx", "alpha": alpha, "specular_reflectance": rgb},
            "roughconductor")


def medium_of(material):
    """Mitsuba's absorbing interior of coloured glass (KHR_materials_volume with a thickness:
    σ = −ln(attenuationColor) / attenuationDistance, no scattering), or None."""
    ext = material.get("extensions", {})
    volume = ext.get("KHR_materials_volume", {})
    distance = volume.get("attenuationDistance")
    transmission = ext.get("KHR_materials_transmission", {}).get("transmissionFactor", 0.0)
    if transmission <= 0 or volume.get("thicknessFactor", 0.0) <= 0 or not distance or distance <= 0:
        return None
    colour = volume.get("attenuationColor", [1.0, 1.0, 1.0])
    sigma = [-math.log(min(max(c, 1e-6), 1.0)) / distance for c in colour]
    # Mitsuba's RGB values lie in 0..1: the largest σ goes in `scale`.
    scale = max(max(sigma), 1e-9)
    return {"type": "homogeneous", "sigma_t": {"type": "rgb", "value": [c / scale for c in sigma]},
            "scale": scale, "albedo": {"type": "rgb", "value": [0.0, 0.0, 0.0]}}


def emission_of(material, textures=None):
    """Area emitter radiance: an RGB value, or the emissive texture times factor and strength."""
    strength = material.get("extensions", {}).get("KHR_materials_emissive_strength", {}).get("emissiveStrength", 1.0)
    e = [c * strength for c in material.get("emissiveFactor", [0, 0, 0])]
    if max(e) <= 0:
        return None
    if "emissiveTexture" in material and textures:
        return textures.colour(material["emissiveTexture"], e)
    return {"type": "rgb", "value": e}


def with_vertex_colors(material, colors):
    """Bevy multiplies the base colour by the (linear) vertex colours: without a base colour
    texture the factor goes into the colours the mesh carries; with one, colours that are all
    alike go into its factor (Mitsuba multiplies no textures; varying ones are left out)."""
    pbr = material.get("pbrMetallicRoughness", {})
    base = pbr.get("baseColorFactor", [1, 1, 1, 1])
    if colors is None:
        return material, None
    if "baseColorTexture" not in pbr:
        return material, [tuple(c[k] * base[k] for k in range(3)) for c in colors]
    if all(tuple(c[:3]) == tuple(colors[0][:3]) for c in colors):
        factor = [base[k] * colors[0][k] for k in range(3)] + base[3:]
        return dict(material, pbrMetallicRoughness=dict(pbr, baseColorFactor=factor)), None
    return material, colors


def triangles(idx, mode):
    """A primitive's triangles as index triples: a list (4), a strip (5, every other one turned
    to keep the winding) or a fan (6), as glTF defines them; degenerate ones left out."""
    if mode == 5:
        faces = [(idx[i], idx[i + 1 + i % 2], idx[i + 2 - i % 2]) for i in range(len(idx) - 2)]
    elif mode == 6:
        faces = [(idx[i], idx[i + 1], idx[0]) for i in range(1, len(idx) - 1)]
    else:
        faces = [(idx[i], idx[i + 1], idx[i + 2]) for i in range(0, len(idx) - 2, 3)]
    return [f for f in faces if len(set(f)) == 3]


def uv_channel(material):
    """The texture coordinates (TEXCOORD_n) the material's textures read: Mitsuba has one set a
    mesh; where its textures name different ones, the base colour's."""
    pbr = material.get("pbrMetallicRoughness", {})
    infos = [pbr.get("baseColorTexture"), pbr.get("metallicRoughnessTexture"),
             material.get("emissiveTexture"), material.get("normalTexture")]
    channels = [i.get("texCoord", 0) for i in infos if i]
    if len(set(channels)) > 1:
        print(f"reference.py: textures on TEXCOORD {sorted(set(channels))}; all read the first", file=sys.stderr)
    return channels[0] if channels else 0


def build_scene(path, width, height, tmp, max_depth=16):
    import mitsuba as mi

    gltf, buffers, folder = load(path)
    textures = Textures(gltf, buffers, folder, tmp)
    materials = gltf.get("materials", [])
    lights = gltf.get("extensions", {}).get("KHR_lights_punctual", {}).get("lights", [])
    scene = {"type": "scene", "integrator": {"type": "path", "max_depth": max_depth, "rr_depth": 8}}
    mapping = []
    camera = None
    for node, world in walk(gltf):
        name = node.get("name", "node")
        if "mesh" in node:
            for k, prim in enumerate(gltf["meshes"][node["mesh"]]["primitives"]):
                mode = prim.get("mode", 4)
                if mode not in (4, 5, 6):
                    continue  # points and lines
                positions = [transform_point(world, p) for p in accessor(gltf, buffers, prim["attributes"]["POSITION"])]
                if "indices" in prim:
                    idx = [i[0] for i in accessor(gltf, buffers, prim["indices"])]
                else:
                    idx = list(range(len(positions)))
                faces = triangles(idx, mode)
                if sum(world[r][0] * (world[(r + 1) % 3][1] * world[(r + 2) % 3][2] - world[(r + 1) % 3][2] * world[(r + 2) % 3][1]) for r in range(3)) < 0:
                    faces = [(a, c, b) for a, b, c in faces]
                ply = os.path.join(tmp, f"{len(scene)}.ply")
                attributes = prim["attributes"]
                material = materials[prim["material"]] if "material" in prim else {}
                uv_set = f"TEXCOORD_{uv_channel(material)}"
                uvs = accessor(gltf, buffers, attributes[uv_set]) if uv_set in attributes else None
                colors = accessor(gltf, buffers, attributes["COLOR_0"]) if "COLOR_0" in attributes else None
                material, colors = with_vertex_colors(material, colors)
                normals = [transform_normal(world, n) for n in accessor(gltf, buffers, attributes["NORMAL"])] \
                    if "NORMAL" in attributes else None
                write_ply(ply, positions, faces, uvs, colors, normals)
                opposite = green_opposite(positions, faces, uvs) if uvs and "normalTexture" in material else True
                bsdf, description = bsdf_of(material, textures, colors is not None, opposite)
                shape = {"type": "ply", "filename": ply, "bsdf": bsdf, "face_normals": normals is None}
                if bsdf["type"] == "mask":
                    # `path` treats a cut-out as opaque to shadow rays (a point light's light
                    # never passes its holes); `volpath` carries them through null surfaces.
                    scene["integrator"]["type"] = "volpath"
                medium = medium_of(material)
                if medium:
                    # Paths inside it lose light along their length: the volumetric path tracer.
                    shape["interior"] = medium
                    scene["integrator"]["type"] = "volpath"
                    description += f" with interior σ {[c * medium['scale'] for c in medium['sigma_t']['value']]}"
                emitted = emission_of(material, textures)
                if emitted:
                    shape["emitter"] = {"type": "area", "radiance": emitted}
                    description += f" + area emitter radiance {emitted.get('value', 'texture')}"
                scene[f"{name}_{k}_{len(scene)}"] = shape
                mapping.append(f"{name}[{k}]: {len(faces)} tris, material '{material.get('name', '')}' -> {description}")
        if "camera" in node and camera is None:
            cam = gltf["cameras"][node["camera"]]
            origin = transform_point(world, [0, 0, 0])
            forward = transform_dir(world, [0, 0, -1])
            up = transform_dir(world, [0, 1, 0])
            if cam.get("type") == "orthographic":
                # Bevy's glTF loader makes the view xmag wide (ScalingMode::FixedHorizontal),
                # not 2·xmag as the glTF spec reads it; its height follows the image's aspect.
                size = ("orthographic", cam["orthographic"]["xmag"])
            else:
                size = ("perspective", math.degrees(cam["perspective"]["yfov"]))
            camera = (origin, [origin[i] + forward[i] for i in range(3)], up, size)
        light = node.get("extensions", {}).get("KHR_lights_punctual")
        if light is not None:
            l = lights[light["light"]]
            kind = l["type"]
            # Bevy's glTF loader reads a light's colour as sRGB (Color::srgb_from_array), so
            # its linear value is what Bevy lights with.
            colour = [srgb_to_linear(c) * l.get("intensity", 1.0) for c in l.get("color", [1, 1, 1])]
            position = transform_point(world, [0, 0, 0])
            direction = transform_dir(world, [0, 0, -1])
            radius = l.get("extras", {}).get("rppm_radius", 0.0)
            if kind != "point" and radius > 0:
                print(f"reference.py: a {kind} light's rppm_radius is left out (a point source)", file=sys.stderr)
            if kind == "point" and radius > 0:
                # A sphere light (bevy_rppm reads `extras.rppm_radius` as PointLight::radius):
                # radiance I/(πr²) from its surface, which neither blocks nor reflects light,
                # as Bevy's lights do not.
                scene[f"light_{len(scene)}"] = {
                    "type": "sphere", "center": position, "radius": radius, "bsdf": {"type": "null"},
                    "emitter": {"type": "area", "radiance": {"type": "rgb", "value": [c / (math.pi * radius * radius) for c in colour]}},
                }
            elif kind == "point":
                scene[f"light_{len(scene)}"] = {"type": "point", "position": position, "intensity": {"type": "rgb", "value": colour}}
            elif kind == "directional":
                scene[f"light_{len(scene)}"] = {"type": "directional", "direction": direction, "irradiance": {"type": "rgb", "value": colour}}
            elif kind == "spot":
                # Mitsuba's own falloff is a ramp in θ; Bevy's, the square of a ramp in cos θ
                # from the outer cone to the inner, is projected as a texture over a cone of
                # full intensity out to the outer angle.
                spot = l.get("spot", {})
                outer = spot.get("outerConeAngle", math.pi / 4)
                inner = min(spot.get("innerConeAngle", 0.0), outer)
                target = [position[i] + direction[i] for i in range(3)]
                scene[f"light_{len(scene)}"] = {
                    "type": "spot",
                    "to_world": mi.ScalarTransform4f().look_at(origin=position, target=target, up=[0, 1, 0] if abs(direction[1]) < 0.9 else [1, 0, 0]),
                    "intensity": {"type": "rgb", "value": colour},
                    "cutoff_angle": math.degrees(outer),
                    "beam_width": math.degrees(outer) * (1.0 - 1e-6),
                    "texture": textures.spot_falloff(inner, outer),
                }
            mapping.append(f"{node.get('name', 'light')}: {kind} {l.get('intensity', 1.0)} x {l.get('color', [1, 1, 1])}")
    # The default scene's, as the geometry (`walk`) and rppm read it.
    scenes = gltf.get("scenes") or [{}]
    sky = scenes[min(gltf.get("scene", 0), len(scenes) - 1)].get("extras", {}).get("rppm_sky")
    if sky is not None:
        # A uniform sky (bevy_rppm::RppmSky): linear radiance from every direction.
        scene["sky"] = {"type": "constant", "radiance": {"type": "rgb", "value": sky}}
        mapping.append(f"sky: constant radiance {sky}")
    if camera is None:
        sys.exit("reference.py: error: the scene has no camera")
    origin, target, up, (kind, size) = camera
    to_world = mi.ScalarTransform4f().look_at(origin=origin, target=target, up=up)
    film = {"type": "hdrfilm", "width": width, "height": height, "rfilter": {"type": "box"}, "pixel_format": "rgb", "component_format": "float32"}
    if kind == "orthographic":
        # Mitsuba's orthographic view spans x in [-1, 1] and y by the film's aspect.
        scene["sensor"] = {"type": "orthographic", "to_world": to_world @ mi.ScalarTransform4f().scale([size / 2, size / 2, 1]), "film": film}
    else:
        scene["sensor"] = {"type": "perspective", "fov": size, "fov_axis": "y", "to_world": to_world, "film": film}
    return scene, mapping


def pick_variant(wanted):
    import mitsuba as mi

    def fallback(why):
        print(f"reference.py: {wanted} unavailable ({why}); using scalar_rgb", file=sys.stderr)
        mi.set_variant("scalar_rgb")
        return "scalar_rgb"

    if wanted.startswith("llvm") and "DRJIT_LIBLLVM_PATH" not in os.environ:
        found = sorted(glob.glob("/usr/lib/*/libLLVM-19.so") + glob.glob("/usr/lib/llvm-19/lib/libLLVM*.so*"))
        if not found:
            # drjit would load the system's older LLVM (Debian 12's 15), which aborts the
            # process at its first kernel ("Cannot select fminimum") instead of failing here.
            return fallback("no libLLVM-19: apt-get install libllvm19")
        os.environ["DRJIT_LIBLLVM_PATH"] = found[0]
    try:
        mi.set_variant(wanted)
        return wanted
    except Exception as e:  # drjit rejects the LLVM it found: fall back, slower but exact
        return fallback(e)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scene")
    parser.add_argument("--out", required=True)
    parser.add_argument("--json")
    parser.add_argument("--width", type=int, default=256)
    parser.add_argument("--height", type=int, default=256)
    parser.add_argument("--spp", type=int, default=1024)
    parser.add_argument("--variant", default="llvm_ad_rgb")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--max-depth", type=int, default=16,
                        help="path vertices; 2 renders direct light only (as rppm with --photon-depth 1)")
    parser.add_argument("--integrator", choices=["path", "ptracer"], default="path",
                        help="ptracer: light tracing, which finds caustics from point lights through glass but "
                             "renders only what the camera sees on non-specular surfaces")
    parser.add_argument("--metal", choices=["bevy", "mitsuba"], default="bevy",
                        help="rough metals as bevy_rppm's model (tools/bevy_metal.py) or Mitsuba's roughconductor")
    args = parser.parse_args()
    variant = pick_variant(args.variant)
    import mitsuba as mi

    global METAL
    METAL = args.metal
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    import bevy_layers
    import bevy_metal

    if METAL == "bevy":
        bevy_metal.register()
    bevy_layers.register()

    with tempfile.TemporaryDirectory() as tmp:
        description, mapping = build_scene(args.scene, args.width, args.height, tmp, args.max_depth)
        if args.integrator == "ptracer":
            if description["integrator"]["type"] != "path":
                sys.exit("reference.py: error: --integrator ptracer renders no media and no cut-outs")
            description["integrator"]["type"] = "ptracer"
        scene = mi.load_dict(description)
        start = time.time()
        bitmap = mi.Bitmap(mi.render(scene, spp=args.spp, seed=args.seed))  # evaluates the render
        seconds = time.time() - start
        bitmap.write(args.out)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(
                {"scene": os.path.basename(args.scene), "width": args.width, "height": args.height, "spp": args.spp,
                 "variant": variant, "integrator": args.integrator, "metal": METAL, "max_depth": args.max_depth, "rr_depth": 8, "seed": args.seed, "mapping": mapping,
                 "time_render_s": round(seconds, 4)},
                f,
                indent=1,
            )
    print(f"wrote {args.out}: {args.spp} spp in {seconds:.1f} s ({variant})", file=sys.stderr)


if __name__ == "__main__":
    main()
