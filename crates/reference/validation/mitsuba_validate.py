#!/usr/bin/env python3
"""Validate the gibake CPU reference against Mitsuba 3 (not run by CI).

Usage:
    pip install mitsuba numpy
    cargo run -p gibake-reference --release --example export_obj -- OUT_DIR --size 128 --spp 1024 [--multi] [--every-bounce]
    python3 crates/reference/validation/mitsuba_validate.py OUT_DIR [--spp N] [--variant scalar_rgb]
        [--rr-depth N] [--max-depth N]

Reads OUT_DIR/scene.json and the OBJ meshes written by the example, renders
the same scene with Mitsuba's `path` integrator (max_depth 2 = direct light
only, max_depth 3 = direct + one bounce), two-sided diffuse BSDFs, a
perspective sensor (fov_axis 'y'), an `independent` sampler, a box
reconstruction filter and one emitter per light of scene.json's `lights`
(`directional`, `point` with intensity in W/sr, `spot`; an older scene.json
with a single `light` is read too; lights with a glTF range are refused by
the exporter: Mitsuba has no range window), and compares with gibake_direct.exr and
gibake_one_bounce.exr:

  rel MSE   = mean over pixels and channels of (x - r)^2 / (r^2 + 0.01),
              x = gibake, r = Mitsuba (the project's metric, gibake_image::rel_mse)
  mean ratio = mean(gibake) / mean(Mitsuba), per channel

and, as the noise floor of that comparison, the rel MSE of a second Mitsuba
render (another seed) against the first. Writes mitsuba_*.exr next to the
inputs and a summary in OUT_DIR/validation.json.

Every bounce (when scene.json has `every_bounce`, export_obj --every-bounce):
Mitsuba's `path` with unbounded depth (`max_depth` -1) and Russian roulette
from `--rr-depth` (default 8, as issue 50's measurement), against
gibake_every_bounce.exr; the same figures, and the every-bounce ÷ one-bounce
ratio of the indirect light (mean of every − direct over mean of one bounce
− direct, per channel) of each renderer. Mitsuba's roulette keeps a path
with probability min(0.95, max throughput): where the albedo is near 1 its
weights grow by 1/0.95 a bounce and its estimate is heavy-tailed (infinite
variance once a path stays in for more than ~20 bounces); `--rr-depth 1026
--max-depth 1026` turns its roulette off and cuts at gibake's cap (1024
bounces, path depth 1026) instead, for such scenes.
"""

import argparse
import json
import os
import sys
import time

import numpy as np


def load_mitsuba(variant):
    try:
        import mitsuba as mi
    except ImportError as e:  # pragma: no cover
        sys.exit(f"cannot import mitsuba ({e}); install it with `pip install mitsuba`")
    mi.set_variant(variant)
    return mi


def look_at(mi, origin, target, up):
    t = mi.ScalarTransform4f
    try:  # Mitsuba >= 3.5: instance method
        return t().look_at(origin=origin, target=target, up=up)
    except TypeError:  # older releases: static method
        return t.look_at(origin=origin, target=target, up=up)


def scene_lights(desc):
    """The lights of scene.json: the `lights` list, or the single `light` of
    files written before the reference had several lights."""
    if "lights" in desc:
        return desc["lights"]
    return [desc["light"]]


def emitter(mi, light):
    """The Mitsuba emitter of one scene.json light (all delta lights)."""
    if "range" in light:  # export_obj refuses these; guard against hand-made files
        sys.exit(f"light {light.get('name', '?')!r} has a range: Mitsuba has no range window")
    if light["type"] == "directional":
        return {
            "type": "directional",
            "direction": light["direction"],
            "irradiance": {"type": "rgb", "value": light["irradiance"]},
        }
    if light["type"] == "point":
        # Mitsuba's `point`: `intensity` is radiant intensity (W/sr), E = I cos / d^2,
        # as glTF's and gibake's point light.
        return {
            "type": "point",
            "position": light["position"],
            "intensity": {"type": "rgb", "value": light["intensity"]},
        }
    if light["type"] != "spot":
        sys.exit(f"unknown light type {light['type']!r}")
    # glTF falloff: saturate((cos θ − cos outer) / w)², w = max(0.001, cos inner − cos outer).
    # Mitsuba's: 1 inside beam_width, linear in θ down to 0 at cutoff_angle. Match the
    # band's ends; the curves differ inside the band, which is negligible only when it
    # is thin (inner ≈ outer).
    outer = np.radians(light["outer_deg"])
    w = max(0.001, np.cos(np.radians(light["inner_deg"])) - np.cos(outer))
    beam = np.degrees(np.arccos(min(1.0, np.cos(outer) + w)))
    if light["outer_deg"] - beam > 0.5:
        print(f"warning: spot falloff band {beam:.2f}..{light['outer_deg']:.2f} deg: Mitsuba's falloff "
              "differs from glTF's inside it; expect differences there", file=sys.stderr)
    p = np.array(light["position"], dtype=float)
    dirn = np.array(light["direction"], dtype=float)
    up = [0.0, 1.0, 0.0] if abs(dirn[1]) < 0.99 else [1.0, 0.0, 0.0]
    return {
        "type": "spot",
        "to_world": look_at(mi, p.tolist(), (p + dirn).tolist(), up),
        "intensity": {"type": "rgb", "value": light["intensity"]},
        "cutoff_angle": float(light["outer_deg"]),
        "beam_width": float(beam),
    }


def scene_dict(mi, desc, out_dir, max_depth, spp, seed, rr_depth=5):
    cam = desc["camera"]
    pos = np.array(cam["position"], dtype=float)
    fwd = np.array(cam["forward"], dtype=float)
    up = np.array(cam["up"], dtype=float)
    d = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": max_depth, "rr_depth": rr_depth,
                       "hide_emitters": True},
        "sensor": {
            "type": "perspective",
            "fov_axis": "y",
            "fov": cam["yfov_deg"],
            "near_clip": cam["znear"],
            "far_clip": 1e7,
            # Mitsuba's camera looks down local +Z with +X to the left; look_at
            # builds exactly that frame from the glTF camera's forward and up.
            "to_world": look_at(mi, pos.tolist(), (pos + fwd).tolist(), up.tolist()),
            "film": {
                "type": "hdrfilm",
                "width": desc["width"],
                "height": desc["height"],
                "rfilter": {"type": "box"},
                "pixel_format": "rgb",
                "component_format": "float32",
            },
            "sampler": {"type": "independent", "sample_count": spp, "seed": seed},
        },
    }
    for i, light in enumerate(scene_lights(desc)):
        d[f"light_{i:03}"] = emitter(mi, light)
    for i, m in enumerate(desc["meshes"]):
        d[f"mesh_{i:03}"] = {
            "type": "obj",
            "filename": os.path.join(out_dir, m["file"]),
            "face_normals": False,
            "bsdf": {
                "type": "twosided",
                "material": {"type": "diffuse", "reflectance": {"type": "rgb", "value": m["albedo"]}},
            },
        }
    return d


def render(mi, desc, out_dir, max_depth, spp, seed, rr_depth=5):
    scene = mi.load_dict(scene_dict(mi, desc, out_dir, max_depth, spp, seed, rr_depth))
    t0 = time.time()
    img = mi.render(scene, spp=spp, seed=seed)
    secs = time.time() - t0
    return np.array(img, dtype=np.float64)[:, :, :3], secs


def read_exr(mi, path):
    bmp = mi.Bitmap(path)
    a = np.array(bmp, dtype=np.float64)
    return a[:, :, :3]


def write_exr(mi, path, img):
    mi.Bitmap(img.astype(np.float32), mi.Bitmap.PixelFormat.RGB).write(path)


def rel_mse(x, r):
    return float(np.mean((x - r) ** 2 / (r * r + 0.01)))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("out_dir")
    ap.add_argument("--spp", type=int, default=None, help="Mitsuba spp (default: the gibake spp)")
    ap.add_argument("--variant", default="scalar_rgb")
    ap.add_argument("--no-noise-floor", action="store_true", help="skip the second Mitsuba render per depth")
    ap.add_argument("--rr-depth", type=int, default=8,
                    help="every bounce: Mitsuba's rr_depth (path depth where Russian roulette starts; default 8)")
    ap.add_argument("--max-depth", type=int, default=-1,
                    help="every bounce: Mitsuba's max_depth (default -1, unbounded)")
    args = ap.parse_args()

    mi = load_mitsuba(args.variant)
    with open(os.path.join(args.out_dir, "scene.json")) as f:
        desc = json.load(f)
    spp = args.spp or desc["spp"]
    kinds = ", ".join(light["type"] for light in scene_lights(desc))
    print(f"scene {desc['source']}: {desc['width']}x{desc['height']}, {desc['triangles']} triangles, "
          f"lights: {kinds}; "
          f"gibake {desc['spp']} spp, Mitsuba {mi.__version__} {args.variant} {spp} spp")
    results = {"mitsuba_version": mi.__version__, "variant": args.variant, "mitsuba_spp": spp,
               "gibake_spp": desc["spp"], "width": desc["width"], "height": desc["height"]}
    depths = [("direct", 2, 5), ("one_bounce", 3, 5)]
    if "every_bounce" in desc["gibake"]:
        depths.append(("every_bounce", args.max_depth, args.rr_depth))
    means = {}
    for name, max_depth, rr_depth in depths:
        ours = read_exr(mi, os.path.join(args.out_dir, desc["gibake"][name]["file"]))
        ref, secs = render(mi, desc, args.out_dir, max_depth, spp, seed=0, rr_depth=rr_depth)
        write_exr(mi, os.path.join(args.out_dir, f"mitsuba_{name}.exr"), ref)
        if ours.shape != ref.shape:
            sys.exit(f"size mismatch: gibake {ours.shape} vs Mitsuba {ref.shape}")
        means[name] = (ours.mean(axis=(0, 1)), ref.mean(axis=(0, 1)))
        r = {
            "max_depth": max_depth,
            "rr_depth": rr_depth,
            "rel_mse": rel_mse(ours, ref),
            "mean_ratio": (ours.mean(axis=(0, 1)) / ref.mean(axis=(0, 1))).tolist(),
            "gibake_mean": ours.mean(axis=(0, 1)).tolist(),
            "mitsuba_mean": ref.mean(axis=(0, 1)).tolist(),
            "gibake_seconds": desc["gibake"][name]["seconds"],
            "mitsuba_seconds": secs,
        }
        if not args.no_noise_floor:
            ref2, _ = render(mi, desc, args.out_dir, max_depth, spp, seed=1, rr_depth=rr_depth)
            r["noise_floor_rel_mse"] = rel_mse(ref2, ref)
        results[name] = r
        ratio = ", ".join(f"{v:.4f}" for v in r["mean_ratio"])
        floor = f", Mitsuba seed-to-seed {r['noise_floor_rel_mse']:.2e}" if "noise_floor_rel_mse" in r else ""
        print(f"{name:>12} (max_depth {max_depth}): rel MSE {r['rel_mse']:.2e}{floor}; "
              f"mean ratio gibake/Mitsuba (R, G, B) = ({ratio}); "
              f"gibake {r['gibake_seconds']:.1f} s, Mitsuba {secs:.1f} s")
    if "every_bounce" in means:
        # What the later bounces add: every-bounce indirect over one-bounce indirect.
        for who, k in [("gibake", 0), ("Mitsuba", 1)]:
            ind_every = means["every_bounce"][k] - means["direct"][k]
            ind_one = means["one_bounce"][k] - means["direct"][k]
            ratio = (ind_every / ind_one).tolist()
            results["every_bounce"][f"{who.lower()}_every_over_one"] = ratio
            print(f"{who:>12}: every-bounce / one-bounce indirect (R, G, B) = "
                  f"({', '.join(f'{v:.4f}' for v in ratio)})")
        g = results["every_bounce"]["gibake_every_over_one"]
        m = results["every_bounce"]["mitsuba_every_over_one"]
        print(f"{'':>12}  gibake / Mitsuba: ({', '.join(f'{a / b:.4f}' for a, b in zip(g, m))}); "
              f"gibake {desc['gibake']['every_bounce'].get('mean_bounces', float('nan')):.2f} "
              f"bounce rays a path, {desc['gibake']['every_bounce'].get('capped', 0)} cut at the cap")
    with open(os.path.join(args.out_dir, "validation.json"), "w") as f:
        json.dump(results, f, indent=2)


if __name__ == "__main__":
    main()
