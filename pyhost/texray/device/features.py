"""The feature set of a compiled scene, and the one function that turns it into
kernel compile-time definitions. Every ``#if`` in kernels/ uses a name emitted here."""
from __future__ import annotations

import dataclasses
import os
from dataclasses import dataclass
from functools import lru_cache

from ..errors import DeviceError


# render(light_sampling=...): every light in every sample, or one light per sample (Features.one_light)
LIGHT_SAMPLING = ("all", "one")


@dataclass(frozen=True)
class Features:
    textures: bool = False         # any material samples a texture
    vertex_normals: bool = False   # any mesh carries per-vertex shading normals
    specular: bool = False         # any material has ks > 0
    shadows: bool = True           # trace shadow rays (False: every light is visible)
    triangles: bool = True         # primitive kinds present in the BVH (without triangles no
    spheres: bool = False          # triangle test is compiled, nor its per-ray setup)
    cylinders: bool = False
    quads: bool = False
    projections: bool = False      # some object generates its uv by a projection mapping
    aovs: bool = False             # the surface stage writes AOVs
    filter_nearest: bool = False   # some texture filters nearest / bilinear / trilinear (texray.texture.FILTERS);
    filter_bilinear: bool = False  # trilinear also computes ray differentials in the surface stage
    filter_trilinear: bool = False
    filter_anisotropic: bool = False   # some texture filters anisotropically (MIP levels, ray differentials)
    specular_maps: bool = False    # some material's ks is a texture
    shininess_maps: bool = False   # some material has a shininess_map
    labels: bool = False           # some material has a label
    bump: bool = False             # some material has a bump map (kernels/shading/bump.h)
    normal_maps: bool = False      # some material has a normal map (kernels/shading/bump.h)
    displacement: bool = False     # some quad, sphere or cylinder is displaced on the device (geometry/displace.h)
    displaced_meshes: bool = False # some triangle mesh is displaced on the device (prism shells, DISP_TRIANGLE)
    displaced_curved_maxmip: bool = False  # some sphere or cylinder is displaced by maxmip (disp_maxmip_bisect)
    displaced_trapezoid_maxmip: bool = False  # some trapezoid (convex quad, no parallelogram) by maxmip (the same)
    displaced_mesh_maxmip: bool = False  # some triangle mesh's shells by maxmip (disp_maxmip_mesh)
    displaced_curved_search: bool = False  # some sphere, cylinder or mesh by the search: no macro, an
                                           # input of the AVX-512 rule (avx512)
    instances: bool = False        # some mesh is instanced (two-level BVH: kernels/accel/instance.h)
    adaptive: bool = False         # the fused kernel samples listed pixels and sums Y^2 (texray.renderer.adaptive)
    one_light: bool = False        # each sample takes one of the >= 2 lights (render(light_sampling="one"))
    stack_size: int = 64           # BVH traversal stack; >= the tree's depth
    max_lights: int = 0            # bound on the light count (1, 2, 4 or 8: loops unrolled); 0 = any count

    @classmethod
    def generic(cls, stack_size: int = 128) -> "Features":
        """Every feature compiled in (AOVs aside): the one program that renders any scene
        whose BVH fits ``stack_size``; the benchmark's baseline for specialization."""
        flags = {f.name: True for f in dataclasses.fields(cls) if f.type in (bool, "bool")}
        flags["aovs"] = flags["adaptive"] = flags["one_light"] = False      # render settings, not scene features
        return cls(**flags, stack_size=stack_size, max_lights=0)

    def covers(self, other: "Features") -> bool:
        """True when a program built for ``self`` renders a scene that needs ``other``."""
        for f in dataclasses.fields(self):
            a, b = getattr(self, f.name), getattr(other, f.name)
            if f.name == "stack_size":
                if a < b:
                    return False
            elif f.name == "one_light":              # a different estimator: the same setting only
                if a != b:
                    return False
            elif f.name == "max_lights":
                if a and (not b or a < b):
                    return False
            elif b and not a:
                return False
        return True


def generic_features(needed: Features) -> Features:
    """The generic program's features for a scene that needs ``needed``: every
    capability compiled in; the render settings (shadows, AOVs, adaptive sampling, light sampling) kept."""
    g = Features.generic(stack_size=max(128, needed.stack_size))
    return dataclasses.replace(g, shadows=needed.shadows, aovs=needed.aovs, adaptive=needed.adaptive,
                               one_light=needed.one_light)


def stack_size_for(depth: int) -> int:
    """Smallest of 32, 64, 128, ... that holds a traversal of a tree of ``depth`` levels
    (few distinct values, so few program variants)."""
    size = 32
    while size < depth + 1:
        size *= 2
    return size


def max_lights_for(n: int) -> int:
    """The light-count bound compiled in for ``n`` lights: the next power of two up to 8,
    0 (a runtime loop) above that, so few program variants exist."""
    for bound in (1, 2, 4, 8):
        if n <= bound:
            return bound
    return 0


# Ray packets (kernels/accel/packet.h: the camera rays of TX_PACKET of a pixel's samples,
# and their shadow rays toward each light, traced as one, a vector lane each) per device
# kind, where they measured faster: PoCL's CPU device, whose LLVM turns the vector
# arithmetic into AVX2 or AVX-512 code (the width: below). Every scene kind gained at 16 spp (the bench scenes, the showcase, instances:
# 0.5-0.97 of the scalar frame; README, Performance). A launch summing fewer samples per
# pixel than the packet has lanes would fill too few (one pixel's packets measured slower at
# 1 and 2 spp): several pixels per work-item fill them (pixels_per_item), in adaptive
# sampling's rounds too. GPUs already spread work-items across SIMD lanes. Intel's CPU
# runtime does too (16 wide). Its vectorized kernels ran the bench scenes at 1.5-2x the frame time of packets
# of 8 in work-groups of one (TEXRAY_PACKET=8: texray.device.opencl.PACKET_LOCAL_SIZES), which
# come within 10% of PoCL's packets, but it builds the packet programs 2-3x slower (a cold
# build of the showcase's program: 47 s against 14 s; the globe's 4.7 against 2.2), so the
# packets stay the user's choice there (2026-12-03, this Xeon; README, Performance).
PACKET_WIDTHS = {"pocl": 16}
# 16 lanes: first for scenes of triangles alone (after the uniform shear, accel/packet.h
# triangle_packet: textured meshes 0.83-0.92 of the frame time of 8 lanes at 1 to 16 spp on a
# Xeon and on this AMD EPYC, the 1M-triangle mesh 0.96), since the per-packet box planes and
# movmskps (accel/packet.h TX_PACKET_OCTANT, core/builtins.h) for every scene: 2026-12-06, AMD
# EPYC, PoCL's LLVM 14 emitting AVX2, tools/ab.py with TEXRAY_PACKET=8 against 16 (medians of
# 3-5 interleaved rounds of 5-7 frames): brick wall 0.91, grazing quad 0.87, globe 0.97 (512x256
# at 4 spp, 512x384 at 16), bumped globe 0.95, showcase 0.99, mixed 1.00 (512x384, 4 spp). The
# earlier code measured globe 0.98-1.02 and grazing quad 1.04-1.2 there, so 8 lanes were the rule.
# Batches of rays (texray.renderer.trace.Tracer: one ray per pixel, neighbouring pixels' rays in
# a packet) take TRACE_PACKET_WIDTHS: on the AMD EPYC 8 lanes traced the bench's 1M-triangle
# mesh faster than 16 (primary rays 12.1 and 13.6 against 11.9 and 11.6 Mrays/s, shadow rays
# 10.7 and 10.7 against 9.3 and 8.8; 2026-12-06, ``TEXRAY_PACKET=8|16 texray bench --scenes ''
# --repeat 9``, two alternations; with AVX-512, 15.9 / 15.6 against 15.9 / 15.8 primary and
# 12.4 / 12.3 against 11.5 / 11.3 shadow).
TRACE_PACKET_WIDTHS = {"pocl": 8}
# AVX-512 (kernels/texray.cl TX_AVX512) for PoCL's programs where the CPU runs it
# (:func:`cpu_avx512`): PoCL 3.0's LLVM 14 knows no Zen 4 and compiles for Zen 3 (AVX2) on this
# AMD EPYC, which has AVX-512; a target attribute over the program lifts that. Measured there
# (2026-12-06, tools/ab.py, both at 16 lanes, TEXRAY_AVX512=0 against 1; texray bench --scenes ''
# for rays): textured meshes 0.92, the Tracer's primary rays 1.05 times the rate at 8 lanes
# (shadow rays equal), but brick wall 1.05-1.10, grazing quad 1.02, globe 0.98: the lane-by-lane
# surface code (bump mapping, texel lookups) ran slower. So scenes of triangles alone
# (triangles_only, then) and the Tracer took it, the others not. Once the surfaces were
# packets too (kernels/shading/surface_packet.h), the others gained as well (2026-12-07, the
# same machine and A/B, TEXRAY_AVX512=1 against the rule then, medians of 3-5 interleaved rounds
# of 5-7 frames, 512x256 at 4 spp): grazing quad 0.80, globe 0.91, brick wall 0.94, bumped globe
# 0.96, mixed 0.94, showcase 0.995, displaced wall 0.87, terrain 0.90, scenes/displacement's brick
# wall 0.84 and curved maxmip 0.89 (384x288); but the planet 1.29 and the torus 1.035 (384x288):
# a sphere or mesh displaced by the search (geometry/displace.h's lane-by-lane march) ran slower.
# So every packet program takes it but those (Features.displaced_curved_search), since
# 2026-12-07 those without shadow rays too (they have packets now).
PACKET_MIN_SAMPLES = 4        # the samples per launch the rules assume when not told


def packet_width(f: Features, device_kind: str | None, samples: int = PACKET_MIN_SAMPLES,
                 rays: bool = False) -> int:
    """TX_PACKET for a program of features ``f`` on a device of ``device_kind``
    (``texray.device.opencl``'s kinds) whose fused launches sum ``samples`` samples per
    pixel: the kind's width from :data:`PACKET_WIDTHS` (:data:`TRACE_PACKET_WIDTHS` with
    ``rays``: a program tracing batches of rays, :func:`trace_packet_width`) at any count (:func:`pixels_per_item`
    fills the lanes), with or without shadow rays; else 0 (no packets). ``TEXRAY_PACKET`` (0, 8 or 16)
    overrides the rule for A/B runs. The images are the same whatever the width (accel/packet.h says when a
    closest hit may differ: within rounding of another hit; of every scene at 80x60, 3 and 16 spp,
    3 pixels of scenes/displacement/torus_search.toml at 16 spp, by 9e-8)."""
    override = os.environ.get("TEXRAY_PACKET")
    if override is not None and override.strip() != "":
        if override.strip() not in ("0", "8", "16"):
            raise DeviceError(f"TEXRAY_PACKET: expected 0, 8 or 16, got {override!r}")
        width = int(override)
    else:
        width = (TRACE_PACKET_WIDTHS if rays else PACKET_WIDTHS).get(device_kind, 0)
    return width


@lru_cache(maxsize=1)
def cpu_avx512() -> bool:
    """Whether this CPU and its OS run AVX-512 (F, VL, BW, DQ: numpy's runtime check of the CPU
    and of the OS saving its registers; False where numpy does not say). PoCL's CPU device is
    this CPU."""
    try:
        from numpy._core._multiarray_umath import __cpu_features__ as cpu
    except ImportError:
        try:                                              # numpy 1.x
            from numpy.core._multiarray_umath import __cpu_features__ as cpu
        except ImportError:
            return False
    return all(cpu.get(name, False) for name in ("AVX512F", "AVX512VL", "AVX512BW", "AVX512DQ"))


def avx512(f: Features, device_kind: str | None, rays: bool = False) -> bool:
    """TX_AVX512 for a program of features ``f`` on a device of ``device_kind``: PoCL's device
    on a CPU with AVX-512 (:func:`cpu_avx512`), for the Tracer (``rays``) and every program but
    those with a sphere, cylinder or mesh displaced by the search (the measurements above
    PACKET_WIDTHS). ``TEXRAY_AVX512=0`` turns it off, ``=1`` on
    for every PoCL program (A/B runs); neither where the CPU lacks it."""
    override = os.environ.get("TEXRAY_AVX512", "").strip()
    if override not in ("", "0", "1"):
        raise DeviceError(f"TEXRAY_AVX512: expected 0 or 1, got {override!r}")
    if device_kind != "pocl" or override == "0" or not cpu_avx512():
        return False
    return override == "1" or rays or not f.displaced_curved_search


def trace_packet_width(f: Features, device_kind: str | None) -> int:
    """TX_PACKET for :class:`texray.renderer.trace.Tracer`, whose batches of arbitrary rays
    (the bench's: one per pixel, in raster order) fill a packet with neighbouring pixels' rays,
    not with one pixel's samples as the renderer's packets do: the kind's width of
    :data:`TRACE_PACKET_WIDTHS` for every scene (8 on PoCL, where frames take 16; the
    measurements above it). ``TEXRAY_PACKET`` overrides it as it does :func:`packet_width`."""
    return packet_width(f, device_kind, rays=True)


def light_block(spp: int, lights: int) -> int:
    """kernels/core/sampler.h light_block without adaptive sampling: the light blocks' length
    of one light per sample (the largest power of two up to 8 with ``spp`` a multiple of
    ``lights`` times it; 1 where ``spp`` is no multiple of 2 ``lights``). A test checks it
    against the kernel's."""
    b = 1
    while b < 8 and lights > 0 and spp % (2 * b * lights) == 0:
        b *= 2
    return b


def light_blocks(f: Features, device_kind: str | None, samples: int = PACKET_MIN_SAMPLES) -> bool:
    """TX_LIGHT_BLOCKS: whether the fused kernel packs several pixels' light blocks into a
    packet (stages/fused.cl; one light per sample with packets, not with adaptive sampling or
    instances, whose fused kernel traces one sample at a time): then a packet's shadow rays
    head for one light. Its programs take several pixels per work-item (TX_MULTI_PIXEL)."""
    return bool(f.one_light and not f.adaptive and not f.instances and packet_width(f, device_kind, samples))


def pixels_per_item(f: Features, device_kind: str | None, samples: int = PACKET_MIN_SAMPLES, block: int = 1) -> int:
    """The pixels each work-item of the fused kernel takes (stages/fused.cl's `pixels`): with
    packets (:func:`packet_width`), the count p <= the packet's width whose p x ``samples``
    samples (a fused launch's per pixel), run pixel by pixel through packets of the width,
    leave the fewest empty lanes: the fewest packets per pixel, ceil(p samples / width) / p,
    the smallest such p (1 spp: 8 pixels in a packet of 8; 3 spp: 8 pixels, 24 samples in 3
    packets; 12 spp: 2 pixels in 3 packets, where one pixel took 2 packets of 8 for its 12;
    any multiple of the width: 1); adaptive sampling's rounds take their pixels from the
    list of those still sampled, p at a time. With :func:`light_blocks` and light blocks of
    ``block`` >= 2 samples (:func:`light_block` of the render's spp and light count) that divide
    ``samples``: width / ``block`` pixels, whose packets each hold one block of every pixel
    (one light: 16 lanes, two lights at 16 spp: 2 pixels). Else 1. Each pixel adds the same
    terms in the same order whatever p, so the image does not depend on it."""
    width = packet_width(f, device_kind, samples)
    if not width:
        return 1
    if block > 1 and samples % block == 0 and width % block == 0 and light_blocks(f, device_kind, samples):
        return width // block
    s = max(samples, 1)
    return min(range(1, width + 1), key=lambda p: (-(-p * s // width) / p, p))


def compile_options(f: Features, device_kind: str | None = None,
                    samples: int = PACKET_MIN_SAMPLES, rays: bool = False, stages: bool = True) -> dict[str, int]:
    """``-D`` definitions for the kernels: the only place feature names become macros.
    ``device_kind`` (a Runtime's ``kind``), ``samples`` (per pixel and fused launch) and
    ``rays`` (a program for batches of rays: :class:`texray.renderer.trace.Tracer`) choose the
    packet width (:func:`packet_width`); no device kind: no packets. ``stages``: whether the
    program holds the five stage kernels and the ray kernels (TX_STAGES; always with ``rays``
    or AOVs, and on every device but PoCL). On PoCL a render of the fused pipeline alone
    leaves them out, and with them the helpers only they call (core/common.h) and the scalar
    geometry its packets make unneeded (geometry/dispatch.h): 7-8% fewer instructions in a
    cold build. Elsewhere the two pipelines keep one program: Intel's compiler, which
    vectorizes each program across work-items in its own way, rounded an instanced scene's
    fused image apart from its staged one in the last bits when they were two programs."""
    return {
        "TX_STAGES": int(stages or rays or f.aovs or device_kind != "pocl"),
        "TX_PACKET": packet_width(f, device_kind, samples, rays),
        "TX_AVX512": int(avx512(f, device_kind, rays)),
        "TX_MULTI_PIXEL": int(pixels_per_item(f, device_kind, samples) > 1 or light_blocks(f, device_kind, samples)),
        "TX_LIGHT_BLOCKS": int(light_blocks(f, device_kind, samples) and not rays),
        "TX_TEXTURES": int(f.textures),
        "TX_VERTEX_NORMALS": int(f.vertex_normals),
        "TX_SPECULAR": int(f.specular),
        "TX_SHADOWS": int(f.shadows),
        "TX_TRIANGLES": int(f.triangles),
        "TX_SPHERES": int(f.spheres),
        "TX_CYLINDERS": int(f.cylinders),
        "TX_QUADS": int(f.quads),
        "TX_PROJECTIONS": int(f.projections),
        "TX_AOVS": int(f.aovs),
        "TX_ADAPTIVE": int(f.adaptive),
        "TX_ONE_LIGHT": int(f.one_light),
        "TX_BUMP": int(f.bump),
        "TX_NORMAL_MAPS": int(f.normal_maps),
        "TX_DISPLACEMENT": int(f.displacement),
        "TX_DISP_MESH": int(f.displaced_meshes),
        "TX_DISP_MAXMIP_CURVED": int(f.displaced_curved_maxmip),
        "TX_DISP_MAXMIP_TRAPEZOID": int(f.displaced_trapezoid_maxmip),
        "TX_DISP_MAXMIP_MESH": int(f.displaced_mesh_maxmip),
        "TX_INSTANCES": int(f.instances),
        "TX_STACK_SIZE": int(f.stack_size),
        "TX_MAX_LIGHTS": int(f.max_lights),
        "TX_FILTER_NEAREST": int(f.filter_nearest),
        "TX_FILTER_BILINEAR": int(f.filter_bilinear),
        "TX_FILTER_TRILINEAR": int(f.filter_trilinear),
        "TX_FILTER_ANISOTROPIC": int(f.filter_anisotropic),
        "TX_SPECULAR_MAPS": int(f.specular_maps),
        "TX_SHININESS_MAPS": int(f.shininess_maps),
        "TX_LABELS": int(f.labels),
    }
