#!/usr/bin/env python3
"""Reads a baked `.gibake` asset directory from the format spec alone.

Written from docs/asset-format.md only (not from the Rust sources of
`gibake-asset`), to prove that the spec is enough to read an asset from
another language. It

- decodes `manifest.bin` (header, bincode 2 standard-config payload decoded by
  hand, BLAKE3 trailer; format 4.x: the lights, the shadow-map views of the
  lights after the first, or of every light when the first is a point light,
  and their map size) and checks its values (the views' order, tiles and
  light indices, the lights' VPL counts, no RSM with a point light first),
- checks every listed file's size and BLAKE3 hash,
- reads `vpls.bin` and `vpl_nodes.bin` and checks their records (ranges, the
  map layers, the near-field tree's sums), and `vpl_coherence.bin` (4.2: the
  level-3 nodes' texel coherences, in [0, 1], 1 for an empty node),
- reads the EXR maps (header: single part, scan lines, ZIP, dimensions,
  channels; pixels: no NaN, atlas tiles, RSM `vpl` indices), `light_maps.exr`
  included, and `view_rsms.exr` (4.1: the other lights' views' RSMs, each
  naming only its own light's VPLs),
- reads `vpl_lower.bin` and `vpl_lower_maps.exr` (4.7: each VPL's second
  origin and second hemisphere map, around the opposite of its normal, for
  the light below its horizon): finite origins, zeros without one, the
  stored maps' tiles in record order, no NaN or negative distance, unused
  tiles +inf, no stored map that sees no surface,
- reads `scene_options` (4.4: the `--sun`, `--dynamic`, `--light`,
  `--bake-volume` and `--max-texture-size` the bake applied; `None`: not
  recorded) and checks their values, printing them as the bake's flags,
- reads `ring_vpls` (4.3: per light, how many of its VPLs, the last of its
  range, lie on a directional light's outer rings, outside its view): one
  entry per light or none, each at most the light's VPLs, non-zero only for
  a directional light; ring VPLs are left out of the light-view, RSM and
  light-map surface checks (no RSM texel may name them) and their hemisphere
  maps' origins are lifted by one texel's radius,
- reads `swept_bounds` (4.5: the moving objects' swept box the bake used,
  six f32 bit patterns, or none): nothing else depends on it, so it is
  only checked for its length and NaN,
- reads `later` (4.6: the bounces after the first — the bounces asked for,
  0 for every one; the later VPLs, the last of vpls.bin after every
  light's; whether they were left out; per bounce the light the surfaces
  reflect): the later VPLs are counted with the lights' to make vpl_count,
  and their hemisphere maps' origins are lifted by one member's radius, as
  ring VPLs' are,
- checks the RSM against the first light's VPLs (texel counts, flux shares
  adding up to each VPL, each position at its texel nearest to the
  flux-weighted centroid),
- recomputes map lookups: the light view (the first light's VPL positions
  land on the primary shadow map's surface; not with a point light first,
  whose light_view is an unused face) and each stored hemisphere map
  (surface points reconstructed from the primary shadow map are not nearer
  to the VPL than its map says, and the map's hits are not in front of the
  light's nearest surface), and the viewed lights' maps (each such light's
  VPLs land on the surface of one of its views' maps; a point light's faces
  look along +X, −X, +Y, −Y, +Z, −Z),

and prints a summary. Exit status 0: the asset is valid; 1: a check failed
(the message names the file); 2: usage or a missing Python package.

Needs numpy, OpenEXR (PyPI `OpenEXR` >= 3.3) and blake3 (PyPI `blake3`;
Python's hashlib has no BLAKE3). `scripts/ensure-deps.sh --python` installs
them into `target/pyenv`.
"""

from __future__ import annotations

import argparse
import decimal
import math
import os
import struct
import sys

try:
    import blake3
    import numpy as np
    import OpenEXR
except ImportError as e:  # pragma: no cover - environment problem
    sys.stderr.write(
        f"read_gibake: missing Python package ({e}); install numpy, OpenEXR and "
        "blake3 (pip install numpy OpenEXR blake3, or scripts/ensure-deps.sh --python)\n"
    )
    sys.exit(2)

MAGIC = b"GIBAKE\x00\x01"
READER_MAJOR = 4
READER_MINOR = 8
# LaterSources (4.8): pairs per later VPL, and groups at most.
SOURCES_PER_LATER_VPL = 8
MAX_SOURCE_GROUPS = 256
MAX_PAYLOAD = 16 * 1024 * 1024
MAX_MAP_SIZE = 16384
# Most texels of one map file (an atlas).
MAX_TEXELS = 2**31
NO_MAP = 0xFFFFFFFF
# vpl_lower.bin's `map` of a VPL without a second origin (4.7).
NO_LOWER = 0xFFFFFFFE
# LightRecord.kind.
LIGHT_KINDS = {0: "directional", 1: "spot", 2: "point"}
LIGHT_POINT = 2
# A point light's views: its cube faces, in this order.
POINT_FACES = [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)]
# Fixed-point 1.0 of an RSM texel's flux share (`share` in rsm.exr).
SHARE_ONE = 1 << 24
RECORD = 48
NODES_PER_VPL = 84
LEVEL3_NODES = 64  # level-3 nodes per VPL (the last 64 of its tree)
VPL_ORIGIN_OFFSET = 0.2

VPL_DTYPE = np.dtype(
    [
        ("position", "<f4", (3,)),
        ("area", "<f4"),
        ("normal", "<f4", (3,)),
        ("texels", "<u4"),
        ("flux", "<f4", (3,)),
        ("map", "<u4"),
    ]
)
assert VPL_DTYPE.itemsize == RECORD


class AssetError(Exception):
    """A check failed; the message names the file."""


# ---------------------------------------------------------------------------
# bincode 2, standard configuration (docs/asset-format.md, "Payload encoding").


class Decoder:
    """A cursor over a bincode payload."""

    def __init__(self, data: bytes):
        self.data = data
        self.pos = 0

    def take(self, n: int, what: str) -> bytes:
        if self.pos + n > len(self.data):
            raise AssetError(
                f"manifest.bin: payload ends inside {what} (needs {n} bytes at {self.pos}, "
                f"has {len(self.data) - self.pos})"
            )
        b = self.data[self.pos : self.pos + n]
        self.pos += n
        return b

    def varint(self, what: str, bits: int) -> int:
        tag = self.take(1, what)[0]
        if tag <= 250:
            v = tag
        elif tag == 251:
            v = struct.unpack("<H", self.take(2, what))[0]
        elif tag == 252:
            v = struct.unpack("<I", self.take(4, what))[0]
        elif tag == 253:
            v = struct.unpack("<Q", self.take(8, what))[0]
        else:
            raise AssetError(f"manifest.bin: {what}: invalid varint marker {tag}")
        if v >= 1 << bits:
            raise AssetError(f"manifest.bin: {what}: {v} does not fit u{bits}")
        return v

    def u32(self, what: str) -> int:
        return self.varint(what, 32)

    def u64(self, what: str) -> int:
        return self.varint(what, 64)

    def boolean(self, what: str) -> bool:
        b = self.take(1, what)[0]
        if b > 1:
            raise AssetError(f"manifest.bin: {what}: invalid bool byte {b}")
        return b == 1

    def f32(self, what: str) -> float:
        return struct.unpack("<f", self.take(4, what))[0]

    def f32s(self, n: int, what: str) -> list[float]:
        return list(struct.unpack(f"<{n}f", self.take(4 * n, what)))

    def string(self, what: str) -> str:
        n = self.u64(f"{what} length")
        raw = self.take(n, what)
        try:
            return raw.decode("utf-8")
        except UnicodeDecodeError as e:
            raise AssetError(f"manifest.bin: {what}: not UTF-8 ({e})") from e

    def option(self, what: str) -> bool:
        tag = self.take(1, f"{what} tag")[0]
        if tag > 1:
            raise AssetError(f"manifest.bin: {what}: invalid Option tag {tag}")
        return tag == 1


MAX_LATER_BOUNCES = 256


def read_later_sources(d: Decoder) -> dict | None:
    """The manifest's `later_sources` (4.8): an Option tag, then first
    (Vec<(u32, f32)>: per first-bounce VPL its source group, below 256, and
    its weight in the group's mean, finite and >= 0) and weights
    (Vec<(u32, f32)>: per later VPL 8 pairs of a source group and the share
    of its light whose direct light fell there, largest first, summing to at
    most 1). Lengths are checked against the VPL counts by the caller."""
    if not d.option("later_sources"):
        return None
    def pairs(field: str) -> list[tuple[int, float]]:
        # A Vec<(u32, f32)>: its count bounded before reading on.
        n = d.u64(f"later_sources.{field} length")
        if n > MAX_PAYLOAD:
            raise AssetError(f"manifest.bin: later_sources.{field} holds {n} entries")
        return [
            (d.u32(f"later_sources.{field}[{k}].group"), d.f32(f"later_sources.{field}[{k}].weight"))
            for k in range(n)
        ]

    first = pairs("first")
    weights = pairs("weights")
    if any(
        g >= MAX_SOURCE_GROUPS or not (math.isfinite(w) and w >= 0.0) for g, w in first + weights
    ):
        raise AssetError("manifest.bin: later_sources holds a group out of range or a bad weight")
    for j in range(0, len(weights), SOURCES_PER_LATER_VPL):
        if sum(w for _, w in weights[j : j + SOURCES_PER_LATER_VPL]) > 1.0 + 1e-3:
            raise AssetError(
                f"manifest.bin: later_sources: later VPL {j // SOURCES_PER_LATER_VPL}'s weights sum over 1"
            )
    return {"first": first, "weights": weights}


def read_later(d: Decoder) -> dict | None:
    """The manifest's `later` (4.6): an Option tag, then bounces (u32, 0 for
    every bounce that matters, else N >= 2), vpl_budget (u32, 0 for the
    default), vpls (u32: the last VPLs of vpls.bin), left_out (bool),
    converged (bool), direct ([f32; 3]), per_bounce (Vec<[f32; 3]>, at most
    256), tail ([f32; 3])."""
    if not d.option("later"):
        return None
    r = {
        "bounces": d.u32("later.bounces"),
        "vpl_budget": d.u32("later.vpl_budget"),
        "vpls": d.u32("later.vpls"),
        "left_out": d.boolean("later.left_out"),
        "converged": d.boolean("later.converged"),
        "direct": d.f32s(3, "later.direct"),
    }
    n = d.u64("later.per_bounce length")
    if n > MAX_LATER_BOUNCES:
        raise AssetError(
            f"manifest.bin: later.per_bounce holds {n} bounces (at most {MAX_LATER_BOUNCES})"
        )
    r["per_bounce"] = [d.f32s(3, f"later.per_bounce[{k}]") for k in range(n)]
    r["tail"] = d.f32s(3, "later.tail")
    if r["bounces"] == 1:
        raise AssetError("manifest.bin: later.bounces = 1 (the first bounce alone has no record)")
    if r["left_out"] and r["vpls"]:
        raise AssetError(f"manifest.bin: later is left out, yet holds {r['vpls']} VPLs")
    for v in [r["direct"], r["tail"], *r["per_bounce"]]:
        if not all(x == x and 0.0 <= x < float("inf") for x in v):
            raise AssetError("manifest.bin: later: a light total is negative or not finite")
    return r


def later_vpls(m: dict) -> int:
    """The later bounces' VPLs (4.6), the last of vpls.bin; 0 without."""
    return m["later"]["vpls"] if m.get("later") else 0


def read_light_view(d: Decoder, what: str) -> dict:
    """A LightViewRecord (`light_view`, and each view's `view`)."""
    lv = {}
    lv["directional"] = d.boolean(f"{what}.directional")
    lv["view_proj"] = d.f32s(16, f"{what}.view_proj")
    lv["origin"] = d.f32s(3, f"{what}.origin")
    lv["direction"] = d.f32s(3, f"{what}.direction")
    lv["texel_scale"] = d.f32(f"{what}.texel_scale")
    lv["texel_area"] = d.f32(f"{what}.texel_area")
    return lv


def read_scene_options(d: Decoder) -> dict | None:
    """An Option<SceneOptions> (docs/asset-format.md, `scene_options`)."""
    if not d.option("scene_options"):
        return None
    o: dict = {}
    o["sun"] = None
    if d.option("scene_options.sun"):
        o["sun"] = {
            "azimuth_deg": d.f32("scene_options.sun.azimuth_deg"),
            "elevation_deg": d.f32("scene_options.sun.elevation_deg"),
            "irradiance": d.f32("scene_options.sun.irradiance"),
            "color": d.f32s(3, "scene_options.sun.color"),
        }
    for field in ("dynamic", "lights"):
        n = d.u64(f"scene_options.{field} length")
        o[field] = [d.string(f"scene_options.{field}[{k}]") for k in range(n)]
    o["bake_volume"] = (
        d.f32s(6, "scene_options.bake_volume")
        if d.option("scene_options.bake_volume")
        else None
    )
    o["max_texture_size"] = (
        d.u32("scene_options.max_texture_size")
        if d.option("scene_options.max_texture_size")
        else None
    )
    return o


def check_scene_options(o: dict | None) -> None:
    """scene_options (4.4): the values the bake's flags allow."""
    if o is None:
        return
    sun = o["sun"]
    if sun is not None:
        if not math.isfinite(sun["azimuth_deg"]):
            raise AssetError("manifest.bin: scene_options: sun azimuth is not finite")
        if not 0 < sun["elevation_deg"] <= 90:
            raise AssetError(
                f"manifest.bin: scene_options: sun elevation {sun['elevation_deg']} "
                "is not in (0, 90] degrees"
            )
        if not all(math.isfinite(x) and x >= 0 for x in [sun["irradiance"]] + sun["color"]):
            raise AssetError(
                "manifest.bin: scene_options: sun irradiance or colour is not finite "
                "and non-negative"
            )
    v = o["bake_volume"]
    if v is not None and (
        not all(math.isfinite(x) for x in v) or any(v[k] >= v[k + 3] for k in range(3))
    ):
        raise AssetError(
            f"manifest.bin: scene_options: bake volume {v} is not a finite box with each "
            "minimum below its maximum"
        )
    n = o["max_texture_size"]
    if n is not None and not 1 <= n <= 65536:
        raise AssetError(
            f"manifest.bin: scene_options: largest texture side {n} is not in 1..=65536"
        )


def num(x: float) -> str:
    """An f32 as the shortest decimal that reads back as itself, without an
    exponent (as gibake prints it)."""
    for digits in range(1, 10):
        t = f"{x:.{digits}g}"
        if struct.unpack("<f", struct.pack("<f", float(t)))[0] == x:
            break
    t = format(decimal.Decimal(t), "f")
    if "." in t:
        t = t.rstrip("0").rstrip(".")
    return "0" if t == "-0" and math.copysign(1, x) > 0 else t


def shell_word(w: str) -> str:
    safe = w and all(c.isascii() and (c.isalnum() or c in "_-.,/:=+@%") for c in w)
    return w if safe else "'" + w.replace("'", "'\\''") + "'"


def scene_flags(o: dict | None) -> str:
    """The bake's command-line flags that give these options."""
    if o is None:
        return "not recorded (format 4.3 or older)"
    out = []

    def flag(name: str, value: str) -> str:
        return f"{name}={value}" if value.startswith("-") else f"{name} {value}"

    sun = o["sun"]
    if sun is not None:
        out.append(flag("--sun", f"{num(sun['azimuth_deg'])},{num(sun['elevation_deg'])}"))
        if sun["irradiance"] != 1.0:
            out.append(flag("--sun-irradiance", num(sun["irradiance"])))
        if sun["color"] != [1.0, 1.0, 1.0]:
            out.append(flag("--sun-color", ",".join(num(c) for c in sun["color"])))
    out += [f"--dynamic {shell_word(p)}" for p in sorted(set(o["dynamic"]))]
    out += [f"--light {shell_word(p)}" for p in sorted(set(o["lights"]))]
    if o["bake_volume"] is not None:
        out.append(flag("--bake-volume", ",".join(num(x) for x in o["bake_volume"])))
    if o["max_texture_size"] not in (None, 8192):
        out.append(f"--max-texture-size {o['max_texture_size']}")
    return " ".join(out) or "none (the level as exported)"


def kind_name(light: dict) -> str:
    return LIGHT_KINDS.get(light["kind"], "unknown")


def read_manifest(asset: str) -> dict:
    path = os.path.join(asset, "manifest.bin")
    if not os.path.isfile(path):
        raise AssetError(f"manifest.bin: missing in {asset}")
    with open(path, "rb") as f:
        data = f.read()
    if len(data) < 12:
        raise AssetError(
            f"manifest.bin: {len(data)} bytes, shorter than the 12-byte header"
        )
    if data[:8] != MAGIC:
        raise AssetError(f"manifest.bin: bad magic {data[:8].hex(' ')}")
    major, minor = struct.unpack("<HH", data[8:12])
    if major != READER_MAJOR:
        hint = (
            "re-bake the scene with a gibake that writes it"
            if major < READER_MAJOR
            else "a newer reader is needed"
        )
        raise AssetError(
            f"manifest.bin: asset format {major}.{minor} is not supported by this reader "
            f"(reads {READER_MAJOR}.x, up to {READER_MAJOR}.{READER_MINOR}); {hint}"
        )
    if len(data) < 20:
        raise AssetError("manifest.bin: truncated before the payload length")
    (length,) = struct.unpack("<Q", data[12:20])
    if length > MAX_PAYLOAD:
        raise AssetError(f"manifest.bin: payload length {length} exceeds {MAX_PAYLOAD}")
    if len(data) != 20 + length + 32:
        raise AssetError(
            f"manifest.bin: {len(data)} bytes, expected 20 + {length} + 32 = {52 + length}"
        )
    want = data[20 + length :]
    got = blake3.blake3(data[: 20 + length]).digest()
    if got != want:
        raise AssetError(
            f"manifest.bin: BLAKE3 trailer mismatch (stored {want.hex()[:16]}…, "
            f"computed {got.hex()[:16]}…)"
        )

    d = Decoder(data[20 : 20 + length])
    m: dict = {"major": major, "minor": minor, "payload_len": length}
    m["provenance"] = {
        k: d.string(f"provenance.{k}")
        for k in ("baker_version", "scene_name", "adapter", "backend", "driver")
    }
    s = {}
    s["rsm_size"] = d.u32("settings.rsm_size")
    s["vpl_map_size"] = d.u32("settings.vpl_map_size")
    s["shadow_map_size"] = d.u32("settings.shadow_map_size")
    s["threshold"] = d.f32("settings.threshold")
    s["vpl_budget"] = (
        d.u32("settings.vpl_budget") if d.option("settings.vpl_budget") else None
    )
    m["settings"] = s
    m["static_scene_hash"] = d.take(32, "static_scene_hash")
    m["light_view"] = read_light_view(d, "light_view")
    m["vpl_count"] = d.u32("vpl_count")
    m["map_count"] = d.u32("map_count")
    m["has_dynamic"] = d.boolean("has_dynamic")
    n = d.u64("files length")
    files = []
    for i in range(n):
        name = d.string(f"files[{i}].name")
        size = d.u64(f"files[{i}].size")
        digest = d.take(32, f"files[{i}].blake3")
        files.append((name, size, digest))
    m["files"] = files
    # The baked lights (lights[0] is the one of light_view).
    lights = []
    for i in range(d.u64("lights length")):
        lights.append(
            {
                "name": d.string(f"lights[{i}].name"),
                "kind": d.take(1, f"lights[{i}].kind")[0],
                "color": d.f32s(3, f"lights[{i}].color"),
                "position": d.f32s(3, f"lights[{i}].position"),
                "direction": d.f32s(3, f"lights[{i}].direction"),
                "inner_cone": d.f32(f"lights[{i}].inner_cone"),
                "outer_cone": d.f32(f"lights[{i}].outer_cone"),
                "range": d.f32(f"lights[{i}].range"),
                "vpls": d.u32(f"lights[{i}].vpls"),
            }
        )
    m["lights"] = lights
    # The shadow-map views of lights[1..] and their maps' resolution.
    views = []
    for i in range(d.u64("views length")):
        views.append(
            {
                "light": d.u32(f"views[{i}].light"),
                "view": read_light_view(d, f"views[{i}].view"),
                "tile": d.u32(f"views[{i}].tile"),
            }
        )
    m["views"] = views
    m["light_map_size"] = d.u32("light_map_size")
    def appended(field: str, most: int, of: str) -> list[int]:
        # A Vec<u32> a minor appends: its count bounded before reading on.
        n = d.u64(f"{field} length")
        if n > most:
            raise AssetError(
                f"manifest.bin: {field} holds {n} entries but there are only {most} {of}"
            )
        return [d.u32(f"{field}[{k}]") for k in range(n)]

    # 4.1 appends view_rsms (Vec<u32>: the views whose RSM view_rsms.exr
    # stores); a 4.0 payload ends before it (no view RSMs). 4.3 appends
    # ring_vpls (Vec<u32>: per light, how many of its VPLs, the last ones of
    # its range, lie on its outer rings); a 4.2 or older payload ends before
    # it (no ring VPLs).
    m["view_rsms"] = appended("view_rsms", len(views), "views") if minor >= 1 else []
    m["ring_vpls"] = appended("ring_vpls", len(lights), "lights") if minor >= 3 else []
    # 4.4 appends scene_options (Option<SceneOptions>: the scene options the
    # bake applied); a 4.3 or older payload ends before it (None: not
    # recorded).
    m["scene_options"] = read_scene_options(d) if minor >= 4 else None
    # 4.5 appends swept_bounds (Vec<u32>: none, or the f32 bit patterns of
    # the moving objects' swept box, min x y z then max x y z); a 4.4 or
    # older payload ends before it (not recorded).
    m["swept_bounds"] = None
    if minor >= 5:
        bits = appended("swept_bounds", 6, "box bounds")
        if len(bits) not in (0, 6):
            raise AssetError(
                f"manifest.bin: swept_bounds holds {len(bits)} values (none, or the box's six)"
            )
        if bits:
            box = [struct.unpack("<f", struct.pack("<I", b))[0] for b in bits]
            if any(v != v for v in box):
                raise AssetError("manifest.bin: swept_bounds holds NaN")
            m["swept_bounds"] = box
    # 4.6 appends later (Option<LaterRecord>: the bounces after the first);
    # a 4.5 or older payload ends before it (the first bounce alone).
    m["later"] = read_later(d) if minor >= 6 else None
    # 4.7 appends lower_map_count (u32 varint: the second hemisphere maps in
    # vpl_lower_maps.exr); a 4.6 or older payload ends before it (0).
    m["lower_map_count"] = d.u32("lower_map_count") if minor >= 7 else 0
    # 4.8 appends later_sources (Option<LaterSources>: where the later VPLs'
    # light came from); a 4.7 or older payload ends before it (none).
    m["later_sources"] = read_later_sources(d) if minor >= 8 else None
    if m["later_sources"] is not None and not (m["later"] or {}).get("vpls", 0):
        raise AssetError("manifest.bin: later_sources listed but no later VPLs")
    extra = length - d.pos
    if extra and minor <= READER_MINOR:
        raise AssetError(
            f"manifest.bin: payload has {extra} bytes after the last field "
            f"(allowed only for a minor newer than {READER_MAJOR}.{READER_MINOR})"
        )
    m["extra_payload_bytes"] = extra
    return m


def view_floats(lv: dict) -> list[float]:
    return (
        lv["view_proj"]
        + lv["origin"]
        + lv["direction"]
        + [lv["texel_scale"], lv["texel_area"]]
    )


def stored_light_maps(m: dict) -> int:
    """How many views store a map in light_maps.exr."""
    return sum(1 for v in m["views"] if v["tile"] != NO_MAP)


def first_viewed_light(m: dict) -> int:
    """The first light with views: 0 when lights[0] is a point light (it has
    no primary map: its six faces are views), else 1 (lights[0] is the
    spot or directional light of light_view)."""
    lights = m["lights"]
    return 0 if lights and lights[0]["kind"] == LIGHT_POINT else 1


def viewed_lights(m: dict) -> str:
    """The lights that have views, in words."""
    if first_viewed_light(m) == 0:
        return "every light (lights[0] is a point light)"
    return "the lights after the first"


def check_views(m: dict) -> None:
    """The lights' views: every light from the first viewed one on (lights[1..],
    or every light when lights[0] is a point light) has its views (a point
    light six, any other one) in light order, each naming its light; the
    stored maps are tiles 0, 1, 2, … in view order. A point light first has
    no primary map, so no RSM: has_dynamic must be false."""
    lights, views = m["lights"], m["views"]
    first = first_viewed_light(m)
    if first == 0 and m["has_dynamic"]:
        raise AssetError(
            f"manifest.bin: lights[0] ('{lights[0]['name']}') is a point light (no primary "
            "map, so no primary RSM) but has_dynamic is true (rsm.exr stored); a point light "
            "first requires has_dynamic false"
        )
    k = next_tile = 0
    for i, light in enumerate(lights[first:], start=first):
        want = 6 if light["kind"] == LIGHT_POINT else 1
        for face in range(want):
            if k >= len(views):
                raise AssetError(
                    f"manifest.bin: views ends at {k}: lights[{i}] ('{light['name']}', "
                    f"{kind_name(light)}) needs {want} views"
                )
            v = views[k]
            if v["light"] != i:
                raise AssetError(
                    f"manifest.bin: views[{k}] is of light {v['light']} but lights[{i}]'s "
                    f"view {face} belongs there"
                )
            if not all(math.isfinite(x) for x in view_floats(v["view"])):
                raise AssetError(f"manifest.bin: views[{k}] holds a non-finite value")
            if v["tile"] != NO_MAP:
                if v["tile"] != next_tile:
                    raise AssetError(
                        f"manifest.bin: views[{k}] stores tile {v['tile']} but the next tile "
                        f"is {next_tile} (tiles are numbered in view order)"
                    )
                next_tile += 1
            k += 1
    if k != len(views):
        raise AssetError(
            f"manifest.bin: {len(views)} views but the lights that have views "
            f"({viewed_lights(m)}) have {k}"
        )
    size = m["light_map_size"]
    if views and not 1 <= size <= MAX_MAP_SIZE:
        raise AssetError(
            f"manifest.bin: light_map_size = {size} outside 1..={MAX_MAP_SIZE} "
            f"({len(views)} views)"
        )
    if not views and size != 0:
        raise AssetError(f"manifest.bin: light_map_size is {size} but there are no views")
    if next_tile > 0:
        cols, rows = atlas_grid(next_tile)
        texels = cols * rows * size**2
        if texels > MAX_TEXELS:
            raise AssetError(
                f"manifest.bin: light-map atlas of {texels} texels exceeds 2^31"
            )


def check_view_rsm_list(m: dict) -> None:
    """view_rsms (4.1): indices into views, strictly ascending; their atlas
    (rsm_size² tiles) at most 2^31 texels."""
    views, rsms = m["views"], m["view_rsms"]
    for k, v in enumerate(rsms):
        if v >= len(views):
            raise AssetError(
                f"manifest.bin: view_rsms[{k}] = {v} is not a view ({len(views)} views)"
            )
        if k > 0 and v <= rsms[k - 1]:
            raise AssetError(
                f"manifest.bin: view_rsms[{k}] = {v} follows {rsms[k - 1]}: the entries "
                "must be strictly ascending"
            )
    if rsms:
        cols, rows = atlas_grid(len(rsms))
        texels = cols * rows * m["settings"]["rsm_size"] ** 2
        if texels > MAX_TEXELS:
            raise AssetError(
                f"manifest.bin: view-RSM atlas of {texels} texels exceeds 2^31"
            )


def check_ring_vpl_list(m: dict) -> None:
    """ring_vpls (4.3): empty, or one entry per light; entry k at most
    lights[k].vpls, and 0 unless lights[k] is directional."""
    lights, rings = m["lights"], m["ring_vpls"]
    if rings and len(rings) != len(lights):
        raise AssetError(
            f"manifest.bin: ring_vpls holds {len(rings)} entries for {len(lights)} lights "
            "(none or one per light)"
        )
    for k, (light, ring) in enumerate(zip(lights, rings)):
        if ring > light["vpls"]:
            raise AssetError(
                f"manifest.bin: ring_vpls[{k}] = {ring} but light {k} ('{light['name']}') "
                f"has only {light['vpls']} VPLs"
            )
        if ring > 0 and light["kind"] != 0:
            raise AssetError(
                f"manifest.bin: ring_vpls[{k}] = {ring} but light {k} ('{light['name']}') "
                f"is a {kind_name(light)} light: only a directional light has outer rings"
            )


def ring_counts(m: dict) -> list[int]:
    """Per light (or the one primary light without light records): how many
    of its VPLs, the last ones of its range, are ring VPLs."""
    n = max(len(m["lights"]), 1)
    return m["ring_vpls"] if m["ring_vpls"] else [0] * n


def ring_mask(m: dict, ranges: list[tuple[int, int]]) -> np.ndarray:
    """Per VPL record: whether its map origin is lifted by one member's
    radius: a ring VPL (the last ring_vpls[k] of light k's range) or a later
    bounce's (4.6: the last later.vpls of vpls.bin, after every light's)."""
    out = np.zeros(m["vpl_count"], dtype=bool)
    for (lo, hi), ring in zip(ranges, ring_counts(m)):
        out[hi - ring : hi] = True
    later = later_vpls(m)
    if later:
        out[m["vpl_count"] - later :] = True
    return out


def check_manifest_values(m: dict) -> list[str]:
    s, lv = m["settings"], m["light_view"]
    for k in ("rsm_size", "vpl_map_size", "shadow_map_size"):
        if not 1 <= s[k] <= MAX_MAP_SIZE:
            raise AssetError(
                f"manifest.bin: settings.{k} = {s[k]} outside 1..={MAX_MAP_SIZE}"
            )
    if not math.isfinite(s["threshold"]):
        raise AssetError("manifest.bin: settings.threshold is not finite")
    if not all(math.isfinite(x) for x in view_floats(lv)):
        raise AssetError("manifest.bin: light_view holds a non-finite value")
    for i, light in enumerate(m["lights"]):
        floats = (
            light["color"]
            + light["position"]
            + light["direction"]
            + [light["inner_cone"], light["outer_cone"], light["range"]]
        )
        if (
            light["kind"] not in LIGHT_KINDS
            or not all(math.isfinite(x) for x in floats)
            or light["range"] < 0
            or any(c < 0 for c in light["color"])
        ):
            raise AssetError(
                f"manifest.bin: lights[{i}] ('{light['name']}') is not a valid light (kind "
                f"{light['kind']}; values finite, colour and range non-negative required)"
            )
    check_views(m)
    check_view_rsm_list(m)
    check_ring_vpl_list(m)
    check_scene_options(m["scene_options"])
    if m["map_count"] > m["vpl_count"]:
        raise AssetError(
            f"manifest.bin: map_count {m['map_count']} > vpl_count {m['vpl_count']}"
        )
    if m["map_count"] > 0:
        cols, rows = atlas_grid(m["map_count"])
        texels = cols * rows * s["vpl_map_size"] ** 2
        if texels > MAX_TEXELS:
            raise AssetError(f"manifest.bin: atlas of {texels} texels exceeds 2^31")
    if m["lower_map_count"] > m["vpl_count"]:
        raise AssetError(
            f"manifest.bin: lower_map_count {m['lower_map_count']} > vpl_count {m['vpl_count']}"
        )
    if m["lower_map_count"] > 0:
        cols, rows = atlas_grid(m["lower_map_count"])
        texels = cols * rows * s["vpl_map_size"] ** 2
        if texels > MAX_TEXELS:
            raise AssetError(f"manifest.bin: second-map atlas of {texels} texels exceeds 2^31")
    required = ["vpls.bin", "vpl_nodes.bin", "primary_depth.exr"]
    if m["minor"] >= 2 and m["vpl_count"] > 0:
        required.append("vpl_coherence.bin")
    if m["map_count"] > 0:
        required.append("vpl_maps.exr")
    if m["has_dynamic"]:
        required.append("rsm.exr")
    if stored_light_maps(m) > 0:
        required.append("light_maps.exr")
    if m["view_rsms"]:
        required.append("view_rsms.exr")
    if m["minor"] >= 7 and m["vpl_count"] > 0:
        required.append("vpl_lower.bin")
    if m["lower_map_count"] > 0:
        required.append("vpl_lower_maps.exr")
    # The format's own names: listed exactly when required (whatever the minor).
    own = [
        "manifest.bin",
        "vpls.bin",
        "vpl_nodes.bin",
        "primary_depth.exr",
        "vpl_maps.exr",
        "rsm.exr",
        "light_maps.exr",
        "view_rsms.exr",
        "vpl_coherence.bin",
        "vpl_lower.bin",
        "vpl_lower_maps.exr",
    ]
    names = [f[0] for f in m["files"]]
    for name in names:
        if "/" in name or "\\" in name or name in ("", ".", ".."):
            raise AssetError(f"manifest.bin: file name {name!r} is not a plain name")
    for name in required:
        if names.count(name) != 1:
            raise AssetError(
                f"manifest.bin: file list holds {name} {names.count(name)} times (must be once)"
            )
    if len(set(names)) != len(names):
        raise AssetError(f"manifest.bin: duplicate names in the file list {names}")
    for name in names:
        if name in own and name not in required:
            raise AssetError(
                f"manifest.bin: file list holds {name}, which the counts say is not stored "
                f"(format {m['major']}.{m['minor']}, vpl_count {m['vpl_count']}, "
                f"map_count {m['map_count']}, lower_map_count {m['lower_map_count']}, "
                f"has_dynamic {m['has_dynamic']}, "
                f"stored light maps {stored_light_maps(m)}, view RSMs {len(m['view_rsms'])})"
            )
    unknown = [n for n in names if n not in required]
    if unknown and m["minor"] <= READER_MINOR:
        raise AssetError(f"manifest.bin: unexpected files in the file list: {unknown}")
    sizes = {f[0]: f[1] for f in m["files"]}
    if sizes["vpls.bin"] != RECORD * m["vpl_count"]:
        raise AssetError(
            f"manifest.bin: vpls.bin listed as {sizes['vpls.bin']} bytes, "
            f"expected 48 · {m['vpl_count']}"
        )
    if sizes["vpl_nodes.bin"] != RECORD * NODES_PER_VPL * m["vpl_count"]:
        raise AssetError(
            f"manifest.bin: vpl_nodes.bin listed as {sizes['vpl_nodes.bin']} bytes, "
            f"expected 48 · 84 · {m['vpl_count']}"
        )
    if "vpl_coherence.bin" in sizes and sizes["vpl_coherence.bin"] != 4 * LEVEL3_NODES * m["vpl_count"]:
        raise AssetError(
            f"manifest.bin: vpl_coherence.bin listed as {sizes['vpl_coherence.bin']} bytes, "
            f"expected 4 · 64 · {m['vpl_count']}"
        )
    if "vpl_lower.bin" in sizes and sizes["vpl_lower.bin"] != 16 * m["vpl_count"]:
        raise AssetError(
            f"manifest.bin: vpl_lower.bin listed as {sizes['vpl_lower.bin']} bytes, "
            f"expected 16 · {m['vpl_count']}"
        )
    return names


def check_later_sources(m: dict, later: int) -> None:
    """later_sources (4.8): one group per first-bounce VPL, eight pairs per
    later VPL (checked once the VPL counts are known to add up)."""
    src = m.get("later_sources")
    if src is not None and (
        len(src["first"]) != m["vpl_count"] - later
        or len(src["weights"]) != later * SOURCES_PER_LATER_VPL
    ):
        raise AssetError(
            "manifest.bin: later_sources' lengths do not match the first-bounce and later VPLs"
        )


def light_vpl_ranges(m: dict) -> list[tuple[int, int]]:
    """Each light's VPLs in vpls.bin, [start, end): the lights' `vpls` counts,
    consecutive in light order (the first light's VPLs first). Without light
    records, every VPL is the primary light's."""
    later = later_vpls(m)
    if later > m["vpl_count"]:
        raise AssetError(
            f"manifest.bin: {later} later VPLs but vpl_count is {m['vpl_count']}"
        )
    if not m["lights"]:
        check_later_sources(m, later)
        return [(0, m["vpl_count"] - later)]
    total = sum(light["vpls"] for light in m["lights"])
    if total + later != m["vpl_count"]:
        raise AssetError(
            f"manifest.bin: the lights' VPL counts add up to {total}"
            + (f" and the later bounces' to {later}" if later else "")
            + f" but vpl_count is {m['vpl_count']}"
        )
    check_later_sources(m, later)
    out, start = [], 0
    for light in m["lights"]:
        out.append((start, start + light["vpls"]))
        start += light["vpls"]
    return out


def check_files(asset: str, m: dict) -> dict[str, bytes]:
    contents = {}
    for name, size, digest in m["files"]:
        path = os.path.join(asset, name)
        if not os.path.isfile(path):
            raise AssetError(f"{name}: listed in the manifest but missing")
        on_disk = os.path.getsize(path)
        if on_disk != size:
            raise AssetError(
                f"{name}: {on_disk} bytes on disk, the manifest says {size}"
            )
        with open(path, "rb") as f:
            data = f.read()
        got = blake3.blake3(data).digest()
        if got != digest:
            raise AssetError(
                f"{name}: BLAKE3 mismatch (manifest {digest.hex()[:16]}…, file {got.hex()[:16]}…)"
            )
        contents[name] = data
    return contents


# ---------------------------------------------------------------------------
# Records.


def check_records(name: str, rec: np.ndarray, map_count: int, nodes: bool) -> None:
    floats = np.concatenate(
        [rec["position"], rec["area"][:, None], rec["normal"], rec["flux"]], axis=1
    )
    bad = ~np.isfinite(floats).all(axis=1)
    if bad.any():
        raise AssetError(
            f"{name}: record {int(np.argmax(bad))} holds a non-finite float"
        )
    if (rec["area"] < 0).any():
        raise AssetError(
            f"{name}: record {int(np.argmax(rec['area'] < 0))} has a negative area"
        )
    if (rec["flux"] < 0).any():
        raise AssetError(
            f"{name}: record {int(np.argmax((rec['flux'] < 0).any(axis=1)))} has negative flux"
        )
    if nodes:
        if (rec["map"] != NO_MAP).any():
            raise AssetError(
                f"{name}: node {int(np.argmax(rec['map'] != NO_MAP))} has map != NO_MAP"
            )
    else:
        ok = (rec["map"] < map_count) | (rec["map"] == NO_MAP)
        if not ok.all():
            raise AssetError(
                f"{name}: VPL {int(np.argmax(~ok))} has map {int(rec['map'][np.argmax(~ok)])}, "
                f"map_count is {map_count}"
            )


def check_vpls(vpls: np.ndarray, m: dict) -> None:
    check_records("vpls.bin", vpls, m["map_count"], nodes=False)
    layers = vpls["map"][vpls["map"] != NO_MAP]
    # Every stored map belongs to one VPL: layers 0, 1, 2, … in VPL order.
    if len(layers) != m["map_count"] or not np.array_equal(
        layers, np.arange(m["map_count"])
    ):
        raise AssetError(
            f"vpls.bin: the VPLs' map layers {layers.tolist()} are not 0..{m['map_count']} "
            "in VPL order"
        )
    lengths = np.linalg.norm(vpls["normal"].astype(np.float64), axis=1)
    if len(lengths) and np.abs(lengths - 1).max() > 1e-3:
        raise AssetError(
            f"vpls.bin: VPL {int(np.argmax(np.abs(lengths - 1)))} has a non-unit normal"
        )
    if (vpls["flux"].sum(axis=1) <= 0).any():
        raise AssetError("vpls.bin: a VPL with zero flux (the baker drops those)")


def check_lower(asset: str, m: dict, data: bytes | None) -> str:
    """vpl_lower.bin and vpl_lower_maps.exr (4.7): per VPL a 16-byte record,
    its second origin (three f32) and `map` (u32): NO_LOWER (0xFFFFFFFE)
    without a second origin (origin all zeros), NO_MAP when its second map
    sees no surface, else its tile; the stored maps' tiles 0, 1, … in record
    order, lower_map_count of them; the atlas in vpl_maps.exr's layout, no
    NaN or negative distance, unused tiles +inf, no stored map all +inf."""
    if data is None:
        return "no vpl_lower.bin (format before 4.7, or no VPLs): no second origins"
    rec = np.frombuffer(data, dtype=np.dtype([("origin", "<f4", 3), ("map", "<u4")]))
    if not np.isfinite(rec["origin"]).all():
        i = int(np.flatnonzero(~np.isfinite(rec["origin"]).all(axis=1))[0])
        raise AssetError(f"vpl_lower.bin: VPL {i}'s second origin is not finite")
    none = rec["map"] == NO_LOWER
    if (rec["origin"][none] != 0).any():
        i = int(np.flatnonzero(none & (rec["origin"] != 0).any(axis=1))[0])
        raise AssetError(f"vpl_lower.bin: VPL {i} has no second origin but a non-zero origin")
    stored = rec["map"][(~none) & (rec["map"] != NO_MAP)]
    if not np.array_equal(stored, np.arange(len(stored), dtype=np.uint32)):
        raise AssetError("vpl_lower.bin: the stored second maps' tiles are not 0, 1, 2, … in order")
    if len(stored) != m["lower_map_count"]:
        raise AssetError(
            f"vpl_lower.bin: {len(stored)} VPLs store a second map but lower_map_count is "
            f"{m['lower_map_count']}"
        )
    note = f"vpl_lower.bin: {int((~none).sum())} VPLs with a second origin, {len(stored)} second maps"
    if len(stored) == 0:
        return note
    s = m["settings"]["vpl_map_size"]
    cols, rows = atlas_grid(len(stored))
    atlas = read_exr(asset, "vpl_lower_maps.exr", cols * s, rows * s, {"Z": "f32"})["Z"]
    if (atlas < 0).any():
        raise AssetError("vpl_lower_maps.exr: a negative distance")
    for k in range(cols * rows):
        col, row = k % cols, k // cols
        tile = atlas[row * s : (row + 1) * s, col * s : (col + 1) * s]
        if k >= len(stored) and not np.isposinf(tile).all():
            raise AssetError(f"vpl_lower_maps.exr: unused tile {k} is not all +inf")
        if k < len(stored) and np.isposinf(tile).all():
            raise AssetError(f"vpl_lower_maps.exr: tile {k} sees no surface; it must be NO_MAP")
    return note + f" ({cols * s}×{rows * s} atlas)"


def check_coherence(data: bytes | None, nodes: np.ndarray) -> str:
    """vpl_coherence.bin (4.2): per VPL, LEVEL3_NODES little-endian f32, its
    level-3 nodes' texel coherences in tree order, each in [0, 1] and 1 for an
    empty node (texels 0). Absent before 4.2: every node a cosine lobe."""
    if data is None:
        return "no vpl_coherence.bin (format before 4.2, or no VPLs): cosine lobes"
    c = np.frombuffer(data, dtype="<f4")
    level3 = nodes.reshape(-1, NODES_PER_VPL)[:, NODES_PER_VPL - LEVEL3_NODES :].reshape(-1)
    if len(c) != len(level3):
        raise AssetError(
            f"vpl_coherence.bin: {len(c)} values for {len(level3)} level-3 nodes"
        )
    bad = ~((c >= 0) & (c <= 1))
    if bad.any():
        k = int(np.argmax(bad))
        raise AssetError(
            f"vpl_coherence.bin: VPL {k // LEVEL3_NODES} level-3 node {k % LEVEL3_NODES} "
            f"has coherence {c[k]}, not in [0, 1]"
        )
    empty = (level3["texels"] == 0) & (c != 1)
    if empty.any():
        k = int(np.argmax(empty))
        raise AssetError(
            f"vpl_coherence.bin: VPL {k // LEVEL3_NODES} level-3 node {k % LEVEL3_NODES} "
            f"is empty but has coherence {c[k]}, not 1"
        )
    lit = c[level3["texels"] != 0]
    mean = float(lit.mean()) if len(lit) else 1.0
    return f"vpl_coherence.bin: {len(c)} level-3 coherences, mean {mean:.3f} over lit nodes"


def check_nodes(nodes: np.ndarray, vpls: np.ndarray) -> None:
    check_records("vpl_nodes.bin", nodes, 0, nodes=True)
    v = len(vpls)
    tree = nodes.reshape(v, NODES_PER_VPL)
    empty = tree["texels"] == 0
    zero = (
        (tree["position"] == 0).all(axis=2)
        & (tree["normal"] == 0).all(axis=2)
        & (tree["flux"] == 0).all(axis=2)
        & (tree["area"] == 0)
    )
    if (empty & ~zero).any():
        i, k = np.argwhere(empty & ~zero)[0]
        raise AssetError(
            f"vpl_nodes.bin: VPL {i} node {k} has texels = 0 but is not all zeros"
        )
    levels = [(0, 4, 2), (4, 20, 4), (20, 84, 8)]
    for lo, hi, side in levels:
        lvl = tree[:, lo:hi]
        texels = lvl["texels"].sum(axis=1, dtype=np.int64)
        if not np.array_equal(texels, vpls["texels"].astype(np.int64)):
            i = int(np.argmax(texels != vpls["texels"]))
            raise AssetError(
                f"vpl_nodes.bin: VPL {i} level {side}×{side} holds {texels[i]} texels, "
                f"the VPL {vpls['texels'][i]}"
            )
        flux = lvl["flux"].astype(np.float64).sum(axis=1)
        ref = vpls["flux"].astype(np.float64)
        err = np.abs(flux - ref) - (1e-4 * np.abs(ref) + 1e-12)
        if (err > 0).any():
            i = int(np.argwhere(err > 0)[0][0])
            raise AssetError(
                f"vpl_nodes.bin: VPL {i} level {side}×{side} flux sums to {flux[i].tolist()}, "
                f"the VPL's is {ref[i].tolist()}"
            )
        if lo > 0:
            # Parent (l, i, j) = sum of children (l+1, 2i+a, 2j+b).
            plo, _, pside = levels[levels.index((lo, hi, side)) - 1]
            for j in range(pside):
                for i in range(pside):
                    parent = tree["texels"][:, plo + j * pside + i].astype(np.int64)
                    kids = sum(
                        tree["texels"][:, lo + (2 * j + b) * side + 2 * i + a].astype(
                            np.int64
                        )
                        for a in (0, 1)
                        for b in (0, 1)
                    )
                    if not np.array_equal(parent, kids):
                        w = int(np.argmax(parent != kids))
                        raise AssetError(
                            f"vpl_nodes.bin: VPL {w} node ({pside}×{pside}: {i}, {j}) holds "
                            f"{parent[w]} texels, its children {kids[w]}"
                        )


# ---------------------------------------------------------------------------
# EXR.


def atlas_grid(map_count: int) -> tuple[int, int]:
    cols = math.isqrt(map_count)
    if cols * cols < map_count:
        cols += 1
    rows = -(-map_count // cols)
    return cols, rows


def read_exr(asset: str, name: str, width: int, height: int, channels: dict) -> dict:
    """Reads `name` and checks its header; returns {channel: array[y, x]}."""
    path = os.path.join(asset, name)
    try:
        f = OpenEXR.File(path, separate_channels=True)
    except Exception as e:  # OpenEXR raises plain RuntimeError / others
        raise AssetError(f"{name}: OpenEXR cannot read it: {e}") from e
    if len(f.parts) != 1:
        raise AssetError(f"{name}: {len(f.parts)} parts, expected one")
    h = f.header()
    if h.get("type") not in (None, OpenEXR.scanlineimage):
        raise AssetError(f"{name}: storage {h.get('type')}, expected scan lines")
    if h.get("compression") != OpenEXR.ZIP_COMPRESSION:
        raise AssetError(f"{name}: compression {h.get('compression')}, expected ZIP")
    if h.get("lineOrder") != OpenEXR.INCREASING_Y:
        raise AssetError(
            f"{name}: line order {h.get('lineOrder')}, expected increasing y"
        )
    lo, hi = h["dataWindow"]
    if tuple(lo) != (0, 0) or tuple(hi) != (width - 1, height - 1):
        raise AssetError(
            f"{name}: data window {tuple(lo)}..{tuple(hi)}, expected (0, 0)..({width - 1}, {height - 1})"
        )
    if h.get("name"):
        raise AssetError(
            f"{name}: the part is named {h['name']!r} (single layer, no name expected)"
        )
    # Unknown channels are ignored (a newer minor may add some).
    names = [c.name for c in h["channels"]]
    out = {}
    chans = f.channels()
    for cname, ctype in channels.items():
        if cname not in chans:
            raise AssetError(f"{name}: no channel {cname} (has {names})")
        px = chans[cname].pixels
        want = np.float32 if ctype == "f32" else np.uint32
        if px.dtype != want:
            raise AssetError(
                f"{name}: channel {cname} is {px.dtype}, expected {np.dtype(want)}"
            )
        if px.shape != (height, width):
            raise AssetError(
                f"{name}: channel {cname} is {px.shape}, expected {(height, width)}"
            )
        if ctype == "f32" and np.isnan(px).any():
            raise AssetError(f"{name}: channel {cname} holds NaN")
        out[cname] = px
    return out


# ---------------------------------------------------------------------------
# Lookups (docs/asset-format.md, "Metrics" and "Hemisphere map lookup").


def view_proj_matrix(lv: dict) -> np.ndarray:
    # Column-major: element (row r, column c) is view_proj[c * 4 + r].
    return np.array(lv["view_proj"], dtype=np.float64).reshape(4, 4).T


def lv_metric(lv: dict, p: np.ndarray) -> np.ndarray:
    o = np.array(lv["origin"], dtype=np.float64)
    if lv["directional"]:
        return (p - o) @ np.array(lv["direction"], dtype=np.float64)
    return np.linalg.norm(p - o, axis=-1)


def lv_texel_coords(
    lv: dict, p: np.ndarray, size: int
) -> tuple[np.ndarray, np.ndarray]:
    """Continuous texel coordinates (N, 2) of world points and clip w (N)."""
    vp = view_proj_matrix(lv)
    c = np.concatenate([p, np.ones((len(p), 1))], axis=1) @ vp.T
    ndc = c[:, :2] / c[:, 3:4]
    uv = np.stack([ndc[:, 0] * 0.5 + 0.5, 0.5 - ndc[:, 1] * 0.5], axis=1)
    return uv * size, c[:, 3]


def lv_unproject(lv: dict, depth: np.ndarray) -> np.ndarray:
    """World points of every texel centre of a light-view map with its metric.

    A texel's ray is found by unprojecting its centre through the inverse of
    `view_proj` at the clip depth of a point about as far as the texel's metric
    (near the light, f32 matrix entries make the direction imprecise).
    """
    size = depth.shape[0]
    ys, xs = np.mgrid[0:size, 0:size]
    u = (xs.ravel() + 0.5) / size
    v = (ys.ravel() + 0.5) / size
    ndc = np.stack([u * 2 - 1, 1 - v * 2], axis=1)
    vp = view_proj_matrix(lv)
    inv = np.linalg.inv(vp)
    o = np.array(lv["origin"], dtype=np.float64)
    dirn = np.array(lv["direction"], dtype=np.float64)
    m = depth.ravel().astype(np.float64)
    # Depth of reference: the texel's metric along the light's axis (1 where
    # the texel is empty: any finite depth in front of the light works).
    ref = np.where(np.isfinite(m) & (m > 0), m, 1.0)
    axis = o + ref[:, None] * dirn
    c = np.concatenate([axis, np.ones((len(axis), 1))], axis=1) @ vp.T
    z = c[:, 2] / c[:, 3]
    h = np.concatenate([ndc, z[:, None], np.ones((len(ndc), 1))], axis=1) @ inv.T
    on_ray = h[:, :3] / h[:, 3:4]
    # Empty texels (+inf) come back as non-finite points; the callers keep
    # the finite ones (inf × a zero direction component is NaN, not a fault).
    with np.errstate(invalid="ignore"):
        if lv["directional"]:
            return on_ray + (m - (on_ray - o) @ dirn)[:, None] * dirn
        ray = on_ray - o
        ray /= np.linalg.norm(ray, axis=1, keepdims=True)
        return o + m[:, None] * ray


def hemi_frame(n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    s = 1.0 if n[2] >= 0 else -1.0
    a = -1.0 / (s + n[2])
    b = n[0] * n[1] * a
    t = np.array([1 + s * n[0] * n[0] * a, s * b, -s * n[0]])
    bt = np.array([b, s + n[1] * n[1] * a, -n[1]])
    return t, bt


def hemi_texel_coords(n: np.ndarray, d: np.ndarray, size: int) -> np.ndarray:
    t, bt = hemi_frame(n)
    lx, ly, lz = d @ t, d @ bt, d @ n
    z = np.maximum(lz, 0.0)
    den = np.abs(lx) + np.abs(ly) + z
    px, py = lx / den, ly / den
    e = np.stack([px + py, px - py], axis=-1)
    return (e * 0.5 + 0.5) * size


def hemi_texel_dirs(n: np.ndarray, size: int) -> np.ndarray:
    """World direction of every texel centre, (size, size, 3), [y, x]."""
    t, bt = hemi_frame(n)
    ys, xs = np.mgrid[0:size, 0:size]
    ex = (xs + 0.5) / size * 2 - 1
    ey = (ys + 0.5) / size * 2 - 1
    px, py = (ex + ey) * 0.5, (ex - ey) * 0.5
    local = np.stack([px, py, 1 - np.abs(px) - np.abs(py)], axis=-1)
    local /= np.linalg.norm(local, axis=-1, keepdims=True)
    return local[..., :1] * t + local[..., 1:2] * bt + local[..., 2:3] * n


def edge_on_to_light(lv: dict, grid: np.ndarray, fin: np.ndarray) -> np.ndarray:
    """Texels of a hemisphere map (hit points `grid`, (s, s, 3)) whose surface
    stands edge-on to the light, |cos| < 0.05: the plane through the hit and
    those of a horizontal and a vertical neighbour (any of the four pairs,
    so that texels at the edge of a surface are found too)."""
    dirn = np.array(lv["direction"], dtype=np.float64)
    s = fin.shape[0]
    out = np.zeros(fin.shape, dtype=bool)
    if s < 2:
        return out
    g = np.where(fin[..., None], grid, 0.0)
    pad_g = np.pad(g, ((1, 1), (1, 1), (0, 0)))
    pad_f = np.pad(fin, 1)

    def neighbour(dy: int, dx: int) -> tuple[np.ndarray, np.ndarray]:
        sl = (slice(1 + dy, 1 + dy + s), slice(1 + dx, 1 + dx + s))
        return pad_g[sl] - g, pad_f[sl]

    for hx in (neighbour(0, 1), neighbour(0, -1)):
        for hy in (neighbour(1, 0), neighbour(-1, 0)):
            nrm = np.cross(hx[0], hy[0])
            length = np.linalg.norm(nrm, axis=-1)
            with np.errstate(invalid="ignore", divide="ignore"):
                cos = np.abs(nrm @ dirn) / length
            out |= hx[1] & hy[1] & (length > 0) & (cos < 0.05)
    return out & fin


def neighbourhood(img: np.ndarray, xy: np.ndarray, op) -> np.ndarray:
    """op (np.minimum / np.maximum) over the 3×3 texels around integer xy (clamped)."""
    size_y, size_x = img.shape
    out = None
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            x = np.clip(xy[:, 0] + dx, 0, size_x - 1)
            y = np.clip(xy[:, 1] + dy, 0, size_y - 1)
            v = img[y, x]
            out = v if out is None else op(out, v)
    return out


def check_light_view(
    m: dict, vpls: np.ndarray, primary: np.ndarray, rings: int = 0
) -> str:
    """VPLs sit on lit surfaces: the primary shadow map sees them (`vpls`:
    the first light's, a spot or directional light: with a point light
    first, light_view is an unused face and its VPLs lie on its views' maps,
    checked by check_light_maps). Its last `rings` VPLs (4.3: ring_vpls[0])
    lie on its outer rings, outside the light view: they are not on the
    primary map, and none may project inside it (a texel's margin allowed
    at its edge)."""
    lv, size = m["light_view"], primary.shape[0]
    ring_note = ""
    if rings:
        rp = vpls["position"][len(vpls) - rings :].astype(np.float64)
        rtc, rw = lv_texel_coords(lv, rp, size)
        within = (rw > 0) & (rtc >= 1).all(axis=1) & (rtc < size - 1).all(axis=1)
        if within.any():
            j = int(np.argmax(within))
            raise AssetError(
                f"primary_depth.exr: VPL {len(vpls) - rings + j} is a ring VPL of the first "
                f"light (outer rings, outside the light view) but projects inside it "
                f"(texel {rtc[j].tolist()})"
            )
        vpls = vpls[: len(vpls) - rings]
        ring_note = f" ({rings} ring VPLs outside the light view)"
    if len(vpls) == 0:
        return "no VPLs of the first light" + ring_note
    p = vpls["position"].astype(np.float64)
    tc, w = lv_texel_coords(lv, p, size)
    inside = (w > 0) & (tc >= 0).all(axis=1) & (tc < size).all(axis=1)
    if not inside.all():
        raise AssetError(
            f"primary_depth.exr: VPL {int(np.argmax(~inside))} projects outside the light view "
            f"(texel {tc[np.argmax(~inside)].tolist()})"
        )
    xy = np.floor(tc).astype(np.int64)
    metric = lv_metric(lv, p)
    lo = neighbourhood(primary, xy, np.minimum).astype(np.float64)
    hi = neighbourhood(primary, xy, np.maximum).astype(np.float64)
    foot = lv["texel_scale"] * (1.0 if lv["directional"] else np.maximum(metric, 1e-6))
    tol = 4 * foot + 1e-4 * np.abs(metric)
    ok = (metric >= lo - tol) & (metric <= hi + tol)
    if not ok.all():
        i = int(np.argmax(~ok))
        raise AssetError(
            f"primary_depth.exr: VPL {i} at light-view metric {metric[i]:.4f} but the shadow "
            f"map holds {lo[i]:.4f}..{hi[i]:.4f} around texel {xy[i].tolist()}"
        )
    return (
        f"{len(vpls)} VPL positions of the first light on the primary shadow map's surface"
        + ring_note
    )


def check_rsm_vpls(m: dict, vpls: np.ndarray, rsm: dict, rings: int = 0) -> str:
    """The RSM's `vpl` and `share` channels against vpls.bin: each VPL's
    `texels` is the number of RSM texels clustered into it, their flux
    shares add up to the whole VPL (2^24, up to each share's rounding), a
    texel of no VPL has none, and the VPL's position is the world point of
    the one of its texels nearest to their flux-weighted centroid (the shares
    are the weights: each is the texel's flux over the VPL's). The RSM is
    the first light's (a spot or directional light: a point light first
    stores no RSM): `vpls` are its VPLs (the first `lights[0].vpls`
    records), and no texel names another light's. Its last `rings` VPLs
    (4.3: ring_vpls[0]) lie on its outer rings, outside the light view: no
    texel names them, and the checks above are of the others."""
    lv = m["light_view"]
    size = rsm["Z"].shape[0]
    idx = rsm["vpl"].ravel()
    share = rsm["share"].ravel().astype(np.int64)
    ring = (idx != NO_MAP) & (idx < len(vpls)) & (idx >= len(vpls) - rings)
    if ring.any():
        t = int(np.argmax(ring))
        raise AssetError(
            f"rsm.exr: texel {t} names VPL {int(idx[t])}, one of the first light's "
            f"{rings} ring VPLs (outer rings, outside the light view: none of their "
            "texels is in rsm.exr)"
        )
    vpls = vpls[: len(vpls) - rings]
    other = (idx != NO_MAP) & (idx >= len(vpls))
    if other.any():
        t = int(np.argmax(other))
        raise AssetError(
            f"rsm.exr: texel {t} names VPL {int(idx[t])}, not one of the first light's "
            f"{len(vpls)}"
        )
    counts = np.bincount(idx[idx != NO_MAP], minlength=len(vpls))
    if not np.array_equal(counts, vpls["texels"].astype(np.int64)):
        i = int(np.argmax(counts != vpls["texels"]))
        raise AssetError(
            f"rsm.exr: {counts[i]} texels name VPL {i}, whose record says texels = "
            f"{vpls['texels'][i]}"
        )
    if (share > SHARE_ONE).any() or (share[idx == NO_MAP] != 0).any():
        t = int(np.argmax((share > SHARE_ONE) | ((idx == NO_MAP) & (share != 0))))
        raise AssetError(
            f"rsm.exr: texel {t} has share {int(share[t])} (over 2^24, or outside every VPL)"
        )
    points = lv_unproject(lv, rsm["Z"])
    order = np.argsort(idx, kind="stable")
    starts = np.searchsorted(idx[order], np.arange(len(vpls) + 1))
    tc, _ = lv_texel_coords(lv, vpls["position"].astype(np.float64), size)
    for i in range(len(vpls)):
        sel = order[starts[i] : starts[i + 1]]
        total = int(share[sel].sum())
        if abs(total - SHARE_ONE) > len(sel) // 2 + 1:
            raise AssetError(
                f"rsm.exr: the flux shares of VPL {i}'s texels add up to {total}, "
                f"not the whole VPL ({SHARE_ONE})"
            )
        x, y = (int(c) for c in np.floor(tc[i]))
        if not (0 <= x < size and 0 <= y < size) or idx[y * size + x] != i:
            raise AssetError(
                f"vpls.bin: VPL {i}'s position does not project onto one of its own "
                f"RSM texels (texel {x}, {y})"
            )
        w = share[sel].astype(np.float64)
        centroid = (points[sel] * w[:, None]).sum(axis=0) / w.sum()
        dist = np.linalg.norm(points[sel] - centroid, axis=1)
        own = np.linalg.norm(points[y * size + x] - centroid)
        metric = float(rsm["Z"][y, x])
        foot = lv["texel_scale"] * (1.0 if lv["directional"] else metric)
        pos = vpls["position"][i].astype(np.float64)
        if own > dist.min() + 1e-3 * foot or np.linalg.norm(
            points[y * size + x] - pos
        ) > 1e-2 * foot + 1e-5 * np.linalg.norm(pos):
            raise AssetError(
                f"vpls.bin: VPL {i}'s position {pos.tolist()} is not its RSM texel "
                "nearest to the flux-weighted centroid"
            )
    return (
        f"{len(vpls)} VPLs: texel counts, flux shares and positions match their "
        "RSM texels" + (f" ({rings} ring VPLs have none)" if rings else "")
    )


def check_view_rsms(
    asset: str,
    m: dict,
    ranges: list[tuple[int, int]],
    rings: np.ndarray | None = None,
) -> str:
    """view_rsms.exr (4.1): the atlas (layout of vpl_maps.exr) of the RSMs of
    the views view_rsms lists, tile k the RSM of views[view_rsms[k]], each
    rsm_size², channels Z (f32), share (u32), vpl (u32). Unused tiles hold
    Z +inf, share 0, vpl 0xFFFFFFFF; in each tile no NaN, every vpl names a
    VPL of the view's own light (its range of vpls.bin) or is 0xFFFFFFFF,
    every share is at most 2^24, and 0 where vpl is 0xFFFFFFFF; no texel names
    a ring VPL (4.3: `rings`, per VPL; they lie outside the views)."""
    rsms = m["view_rsms"]
    if not rsms:
        return "no view_rsms.exr (no view stores an RSM)"
    if rings is None:
        rings = ring_mask(m, ranges)
    rs = m["settings"]["rsm_size"]
    cols, rows = atlas_grid(len(rsms))
    ch = read_exr(
        asset,
        "view_rsms.exr",
        cols * rs,
        rows * rs,
        {"Z": "f32", "share": "u32", "vpl": "u32"},
    )
    surface = 0
    for k in range(cols * rows):
        col, row = k % cols, k // cols
        sl = (slice(row * rs, (row + 1) * rs), slice(col * rs, (col + 1) * rs))
        z, share, idx = ch["Z"][sl], ch["share"][sl], ch["vpl"][sl]
        if k >= len(rsms):
            if not (np.isposinf(z).all() and (share == 0).all() and (idx == NO_MAP).all()):
                raise AssetError(
                    f"view_rsms.exr: unused tile {k} is not empty (Z +inf, share 0, "
                    "vpl 0xFFFFFFFF everywhere)"
                )
            continue
        view = rsms[k]
        light = m["views"][view]["light"]
        lo, hi = ranges[light]
        who = f"tile {k} (views[{view}], light {light} '{m['lights'][light]['name']}')"
        bad = (idx != NO_MAP) & ((idx < lo) | (idx >= hi))
        if bad.any():
            y, x = (int(c) for c in np.argwhere(bad)[0])
            raise AssetError(
                f"view_rsms.exr: {who} texel ({x}, {y}) names VPL {int(idx[y, x])}, not "
                f"one of its light's VPLs {lo}..{hi}"
            )
        named = idx[idx != NO_MAP]
        if rings[named].any():
            v = int(named[np.argmax(rings[named])])
            y, x = (int(c) for c in np.argwhere(idx == v)[0])
            raise AssetError(
                f"view_rsms.exr: {who} texel ({x}, {y}) names VPL {v}, a ring VPL (outer "
                "rings, outside the view: none of its texels is in view_rsms.exr)"
            )
        bad = (share > SHARE_ONE) | ((idx == NO_MAP) & (share != 0))
        if bad.any():
            y, x = (int(c) for c in np.argwhere(bad)[0])
            raise AssetError(
                f"view_rsms.exr: {who} texel ({x}, {y}) has share {int(share[y, x])} "
                "(over 2^24, or outside every VPL)"
            )
        surface += int(np.isfinite(z).sum())
    return (
        f"view_rsms.exr: {len(rsms)} view RSMs of {rs}² (views {rsms}), "
        f"{surface} surface texels, each naming only its light's VPLs"
    )


def check_light_maps(
    m: dict,
    vpls: np.ndarray,
    ranges: list[tuple[int, int]],
    atlas: np.ndarray | None,
) -> list[str]:
    """The lights that have views (those after the first, or every light
    when lights[0] is a point light): each view matches its light (a point
    light's faces look along +X, −X, +Y, −Y, +Z, −Z from its position; a
    spot's view from its position along its direction, perspective; a
    directional light's orthographic along its direction), the atlas holds
    the stored maps (unused tiles +inf, each stored map a surface), and each
    such light's VPLs lie on the surface of the map of one of its views
    (but its ring VPLs, 4.3: the last ring_vpls[i] of a directional light's
    range, which lie on its outer rings, outside its view)."""
    views, size, lights = m["views"], m["light_map_size"], m["lights"]
    if lights and (lights[0]["kind"] == 0) != m["light_view"]["directional"]:
        raise AssetError(
            f"manifest.bin: light_view is {'' if m['light_view']['directional'] else 'not '}"
            f"directional but lights[0] is a {kind_name(lights[0])} light"
        )
    first = first_viewed_light(m)
    who = viewed_lights(m)
    if not views:
        return ["no lights with views (one light, not a point light): no views, no light_maps.exr"]
    # Each view against its light.
    face = 0
    for k, v in enumerate(views):
        light = lights[v["light"]]
        lv = v["view"]
        face = face + 1 if k > 0 and views[k - 1]["light"] == v["light"] else 0
        if light["kind"] == LIGHT_POINT:
            want_dir = np.array(POINT_FACES[face], dtype=np.float64)
        else:
            d = np.array(light["direction"], dtype=np.float64)
            want_dir = d / max(np.linalg.norm(d), 1e-30)
        pos = np.array(light["position"], dtype=np.float64)
        ok = lv["directional"] == (light["kind"] == 0) and np.allclose(
            lv["direction"], want_dir, atol=1e-4, rtol=0
        )
        if not lv["directional"]:
            ok = ok and np.allclose(
                lv["origin"], pos, atol=1e-4 * (1 + np.abs(pos).max()), rtol=0
            )
        if not ok:
            raise AssetError(
                f"manifest.bin: views[{k}] (light {v['light']} '{light['name']}', "
                f"{kind_name(light)}, view {face}) looks from {lv['origin']} along "
                f"{lv['direction']} (directional {lv['directional']}); expected along "
                f"{want_dir.tolist()}"
                + ("" if light["kind"] == 0 else f" from {pos.tolist()}")
            )
    stored = stored_light_maps(m)
    tiles: dict[int, np.ndarray] = {}
    if stored:
        cols, rows = atlas_grid(stored)
        for k in range(cols * rows):
            col, row = k % cols, k // cols
            tile = atlas[row * size : (row + 1) * size, col * size : (col + 1) * size]
            if k >= stored and not np.isposinf(tile).all():
                raise AssetError(f"light_maps.exr: unused tile {k} is not all +inf")
            tiles[k] = tile
    for k, v in enumerate(views):
        if v["tile"] != NO_MAP and not np.isfinite(tiles[v["tile"]]).any():
            raise AssetError(
                f"light_maps.exr: views[{k}]'s map (tile {v['tile']}) holds no surface; "
                "its tile must be NO_MAP"
            )
    lines = [
        f"{len(views)} views of {len(lights) - first} lights "
        f"{'after the first' if first else '(every light: lights[0] is a point light)'}: "
        f"{stored} maps "
        f"of {size}² stored"
        + (f" ({atlas.shape[1]}×{atlas.shape[0]} atlas)" if atlas is not None else "")
    ]
    # Each viewed light's VPLs on its maps' surfaces (lights[0]'s too when
    # it is a point light: it has no primary map): the view that holds a
    # VPL most centrally (a point light's face of the VPL's direction).
    checked = skipped = 0
    rings = ring_counts(m)
    for i in range(first, len(lights)):
        lo_i, hi_i = ranges[i]
        hi_i -= rings[i]
        skipped += rings[i]
        if hi_i == lo_i:
            continue
        p = vpls["position"][lo_i:hi_i].astype(np.float64)
        mine = [k for k, v in enumerate(views) if v["light"] == i]
        best = np.full(len(p), np.inf)
        which = np.full(len(p), -1)
        for k in mine:
            lv = views[k]["view"]
            vp = view_proj_matrix(lv)
            c = np.concatenate([p, np.ones((len(p), 1))], axis=1) @ vp.T
            with np.errstate(divide="ignore", invalid="ignore"):
                spread = np.abs(c[:, :2] / c[:, 3:4]).max(axis=1)
            better = (c[:, 3] > 0) & (spread < best)
            best[better] = spread[better]
            which[better] = k
        outside = best > 1 + 1e-4
        if outside.any():
            j = int(np.argmax(outside))
            raise AssetError(
                f"vpls.bin: VPL {lo_i + j} (light {i} '{lights[i]['name']}') is outside "
                "every view of its light"
            )
        for k in mine:
            sel = which == k
            if not sel.any():
                continue
            lv = views[k]["view"]
            tc, _ = lv_texel_coords(lv, p[sel], size)
            xy = np.clip(np.floor(tc).astype(np.int64), 0, max(size - 1, 0))
            metric = lv_metric(lv, p[sel])
            if views[k]["tile"] == NO_MAP:
                # No map stored: no surface in the view, yet a VPL is in it.
                lo = hi = np.full(len(metric), np.inf)
            else:
                tile = tiles[views[k]["tile"]]
                lo = neighbourhood(tile, xy, np.minimum).astype(np.float64)
                hi = neighbourhood(tile, xy, np.maximum).astype(np.float64)
            foot = lv["texel_scale"] * (
                1.0 if lv["directional"] else np.maximum(metric, 1e-6)
            )
            tol = 4 * foot + 1e-4 * np.abs(metric)
            with np.errstate(invalid="ignore"):
                ok = (metric >= lo - tol) & (metric <= hi + tol)
            if not ok.all():
                j = int(np.argmax(~ok))
                t = views[k]["tile"]
                held = (
                    "stores no map (NO_MAP: no surface in the view)"
                    if t == NO_MAP
                    else f"map (tile {t}) holds {lo[j]:.4f}..{hi[j]:.4f} around texel "
                    f"{xy[j].tolist()}"
                )
                raise AssetError(
                    f"light_maps.exr: VPL {lo_i + int(np.flatnonzero(sel)[j])} (light {i} "
                    f"'{lights[i]['name']}') is in views[{k}] at light-view metric "
                    f"{metric[j]:.4f}, but that view {held}"
                )
            checked += int(sel.sum())
    lines.append(
        f"{checked} VPLs of {who} on their views' map surfaces"
        + (f" ({skipped} ring VPLs outside their views not checked)" if skipped else "")
    )
    return lines


def check_hemi_maps(
    m: dict,
    vpls: np.ndarray,
    atlas: np.ndarray | None,
    primary: np.ndarray,
    show: int | None,
    rings: np.ndarray | None = None,
) -> list[str]:
    """Recomputes each stored hemisphere map's lookups against the primary
    shadow map. A map's origin is O = P + n·0.2·sqrt(max(A, 0)/π) with the
    VPL's area A, or for a ring VPL (4.3, `rings` per VPL) one of its
    texels' area A / max(texels, 1)."""
    s = m["settings"]["vpl_map_size"]
    lv = m["light_view"]
    lines = []
    if atlas is None:
        return ["no hemisphere maps stored"]
    if rings is None:
        rings = ring_mask(m, light_vpl_ranges(m))
    cols, rows = atlas_grid(m["map_count"])
    for k in range(m["map_count"], cols * rows):
        col, row = k % cols, k // cols
        tile = atlas[row * s : (row + 1) * s, col * s : (col + 1) * s]
        if not np.isposinf(tile).all():
            raise AssetError(f"vpl_maps.exr: unused tile {k} is not all +inf")
    if (atlas < 0).any():
        raise AssetError("vpl_maps.exr: a negative distance")
    surf = lv_unproject(lv, primary)[np.isfinite(primary.ravel())]
    # A deterministic subset keeps large assets quick (every map still sees
    # thousands of points).
    surf = surf[:: max(1, -(-len(surf) // 20000))]
    size = primary.shape[0]
    pairs = near_ok = hits = hits_ok = skipped = 0
    for i, rec in enumerate(vpls):
        k = int(rec["map"])
        if k == NO_MAP:
            continue
        col, row = k % cols, k // cols
        tile = atlas[row * s : (row + 1) * s, col * s : (col + 1) * s].astype(
            np.float64
        )
        if np.isposinf(tile).all():
            raise AssetError(
                f"vpl_maps.exr: VPL {i}'s map (tile {k}) sees no surface; it must be NO_MAP"
            )
        n = rec["normal"].astype(np.float64)
        area = float(rec["area"])
        if rings[i]:
            area /= max(int(rec["texels"]), 1)
        origin = rec["position"].astype(np.float64) + n * VPL_ORIGIN_OFFSET * math.sqrt(
            max(area, 0.0) / math.pi
        )
        # (a) Surface points the light sees, in the VPL's hemisphere: its map
        # must hold a surface at most that far along their direction.
        d = surf - origin
        dist = np.linalg.norm(d, axis=1)
        dirs = d / np.maximum(dist, 1e-30)[:, None]
        sel = (dirs @ n > 0.1) & (dist > 1e-6)
        tc = hemi_texel_coords(n, dirs[sel], s)
        xy = np.clip(np.floor(tc).astype(np.int64), 0, s - 1)
        stored = neighbourhood(tile, xy, np.minimum)
        ok_a = stored <= dist[sel] * 1.05 + 1e-5
        pairs += int(sel.sum())
        near_ok += int(ok_a.sum())
        # (b) The map's hits: each finite texel's hit point is a surface point,
        # so it cannot be nearer to the light than the primary shadow map says.
        # A surface edge-on to the light (a wall parallel to a sun's rays)
        # has no area in the light's view, so no depth map holds it: its hits
        # are skipped, found by the surface orientation the map's neighbouring
        # hits give (|cos| to the light below 0.05), and counted.
        tdirs = hemi_texel_dirs(n, s)
        with np.errstate(invalid="ignore"):
            grid = origin + tdirs * tile[..., None]
        fin = np.isfinite(tile)
        edge_on = edge_on_to_light(lv, grid, fin)
        skipped += int((fin & edge_on).sum())
        fin &= ~edge_on
        hp = grid[fin]
        ptc, w = lv_texel_coords(lv, hp, size)
        inside = (w > 0) & (ptc >= 0).all(axis=1) & (ptc < size).all(axis=1)
        pxy = np.floor(ptc[inside]).astype(np.int64)
        met = lv_metric(lv, hp[inside])
        lo = neighbourhood(primary, pxy, np.minimum).astype(np.float64)
        foot = lv["texel_scale"] * (1.0 if lv["directional"] else np.maximum(met, 1e-6))
        ok_b = met >= lo - (
            4 * foot + 1e-4 * np.abs(met) + tile[fin][inside] * 2.83 / s
        )
        hits += int(inside.sum())
        hits_ok += int(ok_b.sum())
        if show is None or show == i:
            show = i
            centre = hemi_texel_coords(n, n[None, :], s)[0]
            lines.append(
                f"VPL {i}{' (ring VPL)' if rings[i] else ''}: map tile {k} at atlas column {col}, row {row} "
                f"(texels x {col * s}..{(col + 1) * s}, y {row * s}..{(row + 1) * s}); "
                f"origin {np.round(origin, 4).tolist()}, normal {np.round(n, 4).tolist()}; "
                f"normal direction -> texel {np.floor(centre).astype(int).tolist()} = "
                f"{tile[min(int(centre[1]), s - 1), min(int(centre[0]), s - 1)]:.4f}; "
                f"{int(fin.sum())}/{s * s} texels see a surface; "
                f"{int(ok_a.sum())}/{int(sel.sum())} lit surface points not nearer than the map, "
                f"{int(ok_b.sum())}/{int(inside.sum())} map hits not in front of the light's surface"
            )
    # Texel-centre rays and shadow-map texels disagree at silhouettes; a wrong
    # projection (frame, axes, atlas placement) fails far more than 5 %.
    for what, good, total in (
        ("lit surface points nearer to a VPL than its map says", near_ok, pairs),
        ("hemisphere-map hits in front of the light's nearest surface", hits_ok, hits),
    ):
        if total and good < 0.95 * total:
            raise AssetError(
                f"vpl_maps.exr: {total - good} of {total} {what} (more than 5 %): "
                "the map lookup does not match the spec"
            )
    lines.append(
        f"all {m['map_count']} maps: {near_ok}/{pairs} surface points consistent, "
        f"{hits_ok}/{hits} map hits consistent ({skipped} hits on surfaces edge-on "
        "to the light not checked)"
    )
    return lines


# ---------------------------------------------------------------------------


def read_asset(asset: str, show_vpl: int | None) -> list[str]:
    if not os.path.isdir(asset):
        raise AssetError(f"{asset}: not a directory")
    m = read_manifest(asset)
    names = check_manifest_values(m)
    contents = check_files(asset, m)
    s = m["settings"]
    vpls = np.frombuffer(contents["vpls.bin"], dtype=VPL_DTYPE)
    nodes = np.frombuffer(contents["vpl_nodes.bin"], dtype=VPL_DTYPE)
    check_vpls(vpls, m)
    ranges = light_vpl_ranges(m)
    check_nodes(nodes, vpls)
    coherence_note = check_coherence(contents.get("vpl_coherence.bin"), nodes)
    lower_note = check_lower(asset, m, contents.get("vpl_lower.bin"))
    ss = s["shadow_map_size"]
    primary = read_exr(asset, "primary_depth.exr", ss, ss, {"Z": "f32"})["Z"]
    atlas = None
    if m["map_count"] > 0:
        cols, rows = atlas_grid(m["map_count"])
        ms = s["vpl_map_size"]
        atlas = read_exr(asset, "vpl_maps.exr", cols * ms, rows * ms, {"Z": "f32"})["Z"]
    light_atlas = None
    stored = stored_light_maps(m)
    if stored > 0:
        cols, rows = atlas_grid(stored)
        ls = m["light_map_size"]
        light_atlas = read_exr(
            asset, "light_maps.exr", cols * ls, rows * ls, {"Z": "f32"}
        )["Z"]
    # The first light's VPLs. With a spot or directional light first they lie
    # on the primary map (and its RSM's texels name them); a point light
    # first has no primary map: its VPLs are checked on its views' maps
    # (check_light_maps) and light_view / primary_depth.exr hold one unused
    # face.
    first = vpls[ranges[0][0] : ranges[0][1]]
    rings = ring_mask(m, ranges)
    first_rings = ring_counts(m)[0]
    point_first = first_viewed_light(m) == 0
    rsm_note = (
        "no rsm.exr (lights[0] is a point light: no primary RSM)"
        if point_first
        else "no rsm.exr (no moving objects)"
    )
    if m["has_dynamic"]:
        rs = s["rsm_size"]
        rsm = read_exr(
            asset,
            "rsm.exr",
            rs,
            rs,
            {
                "Z": "f32",
                "share": "u32",
                "vpl": "u32",
            },
        )
        idx = rsm["vpl"]
        ok = (idx < m["vpl_count"]) | (idx == NO_MAP)
        if not ok.all():
            raise AssetError(
                f"rsm.exr: vpl index {int(idx[~ok][0])} >= vpl_count {m['vpl_count']}"
            )
        rsm_note = (
            f"rsm.exr {rs}²: {int(np.isfinite(rsm['Z']).sum())} surface texels; "
            + check_rsm_vpls(m, first, rsm, first_rings)
        )
    if show_vpl is not None and not 0 <= show_vpl < len(vpls):
        raise AssetError(f"--vpl {show_vpl}: the asset has {len(vpls)} VPLs")
    if show_vpl is not None and vpls["map"][show_vpl] == NO_MAP:
        raise AssetError(f"--vpl {show_vpl}: that VPL stores no map")
    if point_first:
        lv_note = (
            "lights[0] is a point light: light_view and primary_depth.exr hold one unused "
            "face; its VPLs are checked on its views' maps"
        )
    else:
        lv_note = check_light_view(m, first, primary, first_rings)
    others = check_light_maps(m, vpls, ranges, light_atlas)
    others.append(check_view_rsms(asset, m, ranges, rings))
    hemi = check_hemi_maps(m, vpls, atlas, primary, show_vpl, rings)
    p = m["provenance"]
    out = [
        f"{asset}: gibake asset {m['major']}.{m['minor']}, manifest payload {m['payload_len']} bytes",
        (
            f"  baked by gibake {p['baker_version']} from {p['scene_name']} on {p['adapter']} "
            f"({p['backend']}, {p['driver']})"
        ),
        (
            f"  settings: rsm {s['rsm_size']}², vpl maps {s['vpl_map_size']}², shadow map "
            f"{s['shadow_map_size']}², threshold {s['threshold']}, vpl budget {s['vpl_budget']}"
        ),
        (
            "  light: "
            + (
                "point (no primary map)"
                if point_first
                else ("directional" if m["light_view"]["directional"] else "spot")
            )
            + "; "
            f"{m['vpl_count']} VPLs, {m['map_count']} maps, dynamic {m['has_dynamic']}"
        ),
        f"  scene flags: {scene_flags(m['scene_options'])}",
        (
            "  baked lights: "
            + (
                ", ".join(
                    f"'{l['name']}' ({kind_name(l)}, {l['vpls']} VPLs)" for l in m["lights"]
                )
                or "none recorded"
            )
        ),
    ]
    out += [
        f"  {r} ring VPLs (outer rings) of light {k} ('{m['lights'][k]['name']}'), the last "
        "of its range: outside its view, their map origins one texel's radius up"
        for k, r in enumerate(m["ring_vpls"])
        if r
    ]
    if m.get("later"):
        lt = m["later"]
        asked = "every bounce that matters" if lt["bounces"] == 0 else f"{lt['bounces']} bounces"
        out.append(
            f"  later bounces ({asked}, {len(lt['per_bounce'])} followed"
            + ("" if lt["converged"] else ", not converged")
            + "): "
            + ("left out" if lt["left_out"] else f"the last {lt['vpls']} VPLs, map origins one member's radius up")
        )
    src = m.get("later_sources")
    if src is not None:
        groups = len({g for g, w in src["first"] if w > 0})
        out.append(
            f"  later sources: the first bounce's {len(src['first'])} VPLs in {groups} groups, "
            f"{len(src['weights'])} weights"
        )
    out += [
        f"  files (manifest order): {', '.join(names)}; all sizes and BLAKE3 hashes match",
        f"  vpl_nodes.bin: {len(nodes)} nodes, level sums match",
        f"  {coherence_note}",
        f"  {lower_note}",
        f"  {rsm_note}",
        f"  light view: {lv_note}",
    ]
    out += [f"  {line}" for line in others]
    out += [f"  {line}" for line in hemi]
    return out


def main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("asset", help="the NAME.gibake directory")
    ap.add_argument(
        "--vpl",
        type=int,
        default=None,
        help="VPL whose map lookup to print (default: the first with a map)",
    )
    args = ap.parse_args(argv)
    try:
        lines = read_asset(args.asset, args.vpl)
    except AssetError as e:
        sys.stderr.write(f"read_gibake: INVALID: {e}\n")
        return 1
    print("\n".join(lines))
    print("OK")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
