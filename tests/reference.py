"""A float64 numpy reference renderer of the same equation as the kernels.

Brute force: every ray against every triangle (Moller-Trumbore in float64),
shadow rays likewise, pixel-centre samples only (render(..., jitter=False)).
Small scenes only. Texels are taken as the device stores them (rounded to
half precision), so that differences measure the kernels' arithmetic, not the
storage format.
"""
import numpy as np

from texray.compile import compile_scene


def camera_rays(scene, width, height):
    eye, fwd, right, up = scene.camera.basis(width / height)
    px, py = np.meshgrid(np.arange(width) + 0.5, np.arange(height) + 0.5)
    x = 2 * px / width - 1
    y = 1 - 2 * py / height
    d = fwd + x[..., None] * right + y[..., None] * up
    return np.broadcast_to(eye, d.shape).reshape(-1, 3), d.reshape(-1, 3)


def intersect(org, dirs, p0, p1, p2, tmax=None):
    """Closest (t, b1, b2, tri) per ray, float64; tri = -1 for a miss. t in (0, tmax)."""
    n = len(org)
    best_t = np.full(n, np.inf) if tmax is None else np.array(tmax, dtype=np.float64).copy()
    best = np.full(n, -1)
    bb1 = np.zeros(n)
    bb2 = np.zeros(n)
    e1, e2 = p1 - p0, p2 - p0
    for chunk in range(0, len(p0), 256):
        sl = slice(chunk, chunk + 256)
        pv = np.cross(dirs[:, None, :], e2[None, sl])
        det = np.einsum("rtk,tk->rt", pv, e1[sl])
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = 1.0 / det
            tv = org[:, None, :] - p0[None, sl]
            b1 = np.einsum("rtk,rtk->rt", tv, pv) * inv
            qv = np.cross(tv, e1[None, sl])
            b2 = np.einsum("rk,rtk->rt", dirs, qv) * inv
            t = np.einsum("rtk,tk->rt", qv, e2[sl]) * inv
            ok = (det != 0) & (b1 >= 0) & (b2 >= 0) & (b1 + b2 <= 1) & (t > 0) & np.isfinite(t)
        t = np.where(ok, t, np.inf)
        j = np.argmin(t, axis=1)
        tj = t[np.arange(n), j]
        better = tj < best_t
        best_t[better] = tj[better]
        best[better] = j[better] + chunk
        bb1[better] = b1[np.arange(n), j][better]
        bb2[better] = b2[np.arange(n), j][better]
    return best_t, bb1, bb2, best


def bilinear(rgba, uv):
    h, w = rgba.shape[:2]
    u = uv[:, 0] - np.floor(uv[:, 0])
    v = uv[:, 1] - np.floor(uv[:, 1])
    x = u * w - 0.5
    y = (1 - v) * h - 0.5
    fx, fy = np.floor(x), np.floor(y)
    ax, ay = (x - fx)[:, None], (y - fy)[:, None]
    x0, y0 = fx.astype(int) % w, fy.astype(int) % h
    x1, y1 = (x0 + 1) % w, (y0 + 1) % h
    t = rgba.astype(np.float16).astype(np.float64)
    return ((t[y0, x0] * (1 - ax) + t[y0, x1] * ax) * (1 - ay) + (t[y1, x0] * (1 - ax) + t[y1, x1] * ax) * ay)


def render_reference(scene, width, height):
    """(rgb (H, W, 3) float64, prim id per pixel (H, W), visibility mask (H, W, L))."""
    cs = compile_scene(scene)
    tris = cs.tri_shade
    p0, p1, p2 = (cs.tri_verts[k].astype(np.float64) for k in ("p0", "p1", "p2"))
    org, d = camera_rays(scene, width, height)
    t, b1, b2, tri = intersect(org, d, p0, p1, p2)
    hit = tri >= 0
    rgb = np.tile(np.asarray(scene.background, np.float64), (len(org), 1))
    nl = len(scene.lights)
    vis_all = np.zeros((len(org), nl), bool)
    if hit.any():
        i = tri[hit]
        B1, B2 = b1[hit][:, None], b2[hit][:, None]
        B0 = 1 - B1 - B2
        p = B0 * p0[i] + B1 * p1[i] + B2 * p2[i]
        ng = np.cross(p1[i] - p0[i], p2[i] - p0[i])
        ng /= np.linalg.norm(ng, axis=1, keepdims=True)
        side = np.where(np.einsum("ij,ij->i", ng, d[hit]) > 0, -1.0, 1.0)[:, None]
        ng *= side
        ns = ng.copy()
        v = tris["v"][i]
        if cs.normals is not None:
            nrm = cs.normals.reshape(-1, 3).astype(np.float64)
            m = B0 * nrm[v[:, 0]] + B1 * nrm[v[:, 1]] + B2 * nrm[v[:, 2]]
            has = (tris["flags"][i] & 1).astype(bool) & (np.linalg.norm(m, axis=1) > 0)
            ns[has] = side[has] * m[has] / np.linalg.norm(m[has], axis=1, keepdims=True)
        mats = cs.materials[tris["material"][i]]
        kd = mats["diffuse"].astype(np.float64)
        ks = mats["specular"].astype(np.float64)
        shin = mats["shininess"].astype(np.float64)
        if cs.textures is not None:
            uvs = cs.uvs.reshape(-1, 2).astype(np.float64)
            uv = B0 * uvs[v[:, 0]] + B1 * uvs[v[:, 1]] + B2 * uvs[v[:, 2]]
            kd, ks, shin = apply_texture_roles(cs, mats, uv, kd, ks, shin)
        view = -d[hit] / np.linalg.norm(d[hit], axis=1, keepdims=True)
        col = np.asarray(scene.ambient, np.float64) * kd
        for li, light in enumerate(scene.lights):
            lp = np.asarray(light.position, np.float64)
            to_l = lp - p
            facing = np.einsum("ij,ij->i", to_l, ng) > 0
            # shadow ray from a point nudged off the surface; brute force any hit in (0, 1)
            so = p + ng * 1e-7 * (1 + np.abs(p).max(axis=1, keepdims=True))
            st, *_ = intersect(so, lp - so, p0, p1, p2, tmax=np.ones(len(so)))
            vis = facing & ~(st < 1.0)
            vis_all[np.flatnonzero(hit), li] = vis
            d2 = np.einsum("ij,ij->i", to_l, to_l)
            lu = to_l / np.sqrt(d2)[:, None]
            ndl = np.einsum("ij,ij->i", ns, lu)
            r = 2 * ndl[:, None] * ns - lu
            rv = np.maximum(np.einsum("ij,ij->i", r, view), 0)
            spec = ks * (rv ** shin)[:, None]
            term = (kd * ndl[:, None] + spec) * (np.asarray(light.intensity, np.float64) / d2[:, None])
            col += np.where((vis & (ndl > 0))[:, None], term, 0)
        rgb[hit] = col
    return rgb.reshape(height, width, 3), tri.reshape(height, width), vis_all.reshape(height, width, nl)


# --- Texture roles and filters (kernels/texture/texture.h), float64 on the stored half texels ---------

def wrap_index(i, n, mode):
    """kernels/texture/wrap.h wrap_index for an int array (mode: 0 repeat, 1 clamp, 2 mirror)."""
    if mode == 1:
        return np.clip(i, 0, n - 1)
    if mode == 2:
        r = np.mod(i, 2 * n)
        return np.where(r < n, r, 2 * n - 1 - r)
    return np.mod(i, n)


def texture_levels(cs, tex_id):
    """The MIP levels of texture-table entry ``tex_id`` as float64 (h, w, 4) arrays, read from the
    packed half texels (level l: max(1, W >> l) x max(1, H >> l), contiguous)."""
    t = cs.textures[tex_id]
    off, w, h = int(t["offset"]), int(t["width"]), int(t["height"])
    texels = cs.texels.astype(np.float64).reshape(-1, 4)
    out = []
    for _ in range(int(t["levels"])):
        out.append(texels[off:off + w * h].reshape(h, w, 4))
        off += w * h
        w, h = max(1, w >> 1), max(1, h >> 1)
    return out


def bilinear_level(level, uv, mode):
    h, w = level.shape[:2]
    x = uv[:, 0] * w - 0.5
    y = (1 - uv[:, 1]) * h - 0.5
    fx, fy = np.floor(x), np.floor(y)
    ax, ay = (x - fx)[:, None], (y - fy)[:, None]
    x0, y0 = wrap_index(fx.astype(np.int64), w, mode), wrap_index(fy.astype(np.int64), h, mode)
    x1, y1 = wrap_index(fx.astype(np.int64) + 1, w, mode), wrap_index(fy.astype(np.int64) + 1, h, mode)
    t = level
    return (t[y0, x0] * (1 - ax) + t[y0, x1] * ax) * (1 - ay) + (t[y1, x0] * (1 - ax) + t[y1, x1] * ax) * ay


def transform_uv(cs, tex_id, uv):
    t = cs.textures[tex_id]
    m0, m1 = t["m0"].astype(np.float64), t["m1"].astype(np.float64)
    a = np.array([[m0[0], m0[1]], [m0[2], m0[3]]])
    return uv @ a.T + m1, a


def sample(cs, tex_id, uv, duv_dx=None, duv_dy=None):
    """(N, 4) float64: entry ``tex_id`` at untransformed (N, 2) uv with its own transform, wrap
    mode and filter; trilinear needs d(uv)/dx, d(uv)/dy (untransformed)."""
    t = cs.textures[tex_id]
    mode, filt = int(t["wrap"]), int(t["filter"])
    uv, a = transform_uv(cs, tex_id, np.asarray(uv, np.float64))
    levels = texture_levels(cs, tex_id)
    if filt == 0:                                   # nearest
        h, w = levels[0].shape[:2]
        x = wrap_index(np.floor(uv[:, 0] * w).astype(np.int64), w, mode)
        y = h - 1 - wrap_index(np.floor(uv[:, 1] * h).astype(np.int64), h, mode)
        return levels[0][y, x]
    if filt == 1 or duv_dx is None:
        return bilinear_level(levels[0], uv, mode)
    if filt == 3:
        return anisotropic(t, levels, uv, duv_dx @ a.T, duv_dy @ a.T, mode)
    lod = texture_lod(t, duv_dx @ a.T, duv_dy @ a.T)
    return trilinear(levels, uv, lod, mode)


def texture_lod(t, duv_dx, duv_dy):
    """The OpenGL level of detail: log2 of the longer footprint axis in level-0 texels."""
    s = np.array([float(t["width"]), float(t["height"])])
    rho2 = np.maximum(np.sum((duv_dx * s) ** 2, axis=1), np.sum((duv_dy * s) ** 2, axis=1))
    with np.errstate(divide="ignore"):
        return 0.5 * np.log2(rho2)


def trilinear(levels, uv, lod, mode):
    lod = np.clip(np.nan_to_num(lod, nan=0.0, neginf=0.0), 0, len(levels) - 1)
    l0 = np.floor(lod).astype(np.int64)
    f = (lod - l0)[:, None]
    out = np.zeros((len(uv), 4))
    for lv in np.unique(l0):
        sel = l0 == lv
        c = bilinear_level(levels[lv], uv[sel], mode)
        if lv + 1 < len(levels):
            c = c * (1 - f[sel]) + bilinear_level(levels[lv + 1], uv[sel], mode) * f[sel]
        out[sel] = c
    return out


def _role(cs, mats, slot, uv, label=False):
    """(values (N, 4), mask) of a material slot's texture at uv (bilinear / nearest only)."""
    ids = mats[slot]
    out = np.zeros((len(uv), 4))
    for tid in np.unique(ids[ids >= 0]):
        sel = ids == tid
        out[sel] = sample(cs, tid, uv[sel])
        if label:
            tuv, _ = transform_uv(cs, tid, uv[sel])
            inside = np.all((tuv >= 0) & (tuv <= 1), axis=1)
            out[np.flatnonzero(sel)[~inside]] = 0.0
    return out, ids >= 0


def apply_texture_roles(cs, mats, uv, kd, ks, shin):
    """kd, ks, n after the diffuse, label, specular and shininess textures (the surface stage)."""
    d, has = _role(cs, mats, "diffuse_tex", uv)
    kd = np.where(has[:, None], kd * d[:, :3], kd)
    lb, has = _role(cs, mats, "label_tex", uv, label=True)
    kd = np.where(has[:, None], kd * (1 - lb[:, 3:]) + lb[:, :3], kd)
    sp, has = _role(cs, mats, "specular_tex", uv)
    ks = np.where(has[:, None], ks * sp[:, :3], ks)
    sh, has = _role(cs, mats, "shininess_tex", uv)
    shin = np.where(has, shin * sh[:, 0], shin)
    return kd, ks, shin


def aniso_footprint(t, duv_dx, duv_dy):
    """kernels/texture/texture.h texture_aniso_footprint in float64: (major, width, n, spacing, axis_uv)
    of the footprints whose transformed screen derivatives are (N, 2) duv_dx, duv_dy: the
    singular values of J = [a b] in level-0 texels (full axis lengths), the probes' width
    max(minor, major / max_aniso, 1), their number ceil(major / width) in [1, max_aniso], their
    spacing on the segment of length major - width, and the major axis in uv per texel."""
    s = np.array([float(t["width"]), float(t["height"])])
    cap = float(t["max_aniso"])
    a, b = duv_dx * s, duv_dy * s
    J = np.stack([a, b], axis=2)                                  # (N, 2, 2), columns a, b
    with np.errstate(invalid="ignore", over="ignore"):
        ok = np.all(np.isfinite(J), axis=(1, 2))
        Jf = np.where(ok[:, None, None], J, 0.0)
        U, sv, _ = np.linalg.svd(Jf)
        major = np.where(ok, sv[:, 0], np.nan)
        with np.errstate(divide="ignore"):
            minor = sv[:, 1]
            width = np.maximum(np.maximum(minor, major / cap), 1.0)
            n = np.clip(np.ceil(major / width), 1, cap)
            n = np.where(np.isfinite(n), n, 1).astype(np.int64)
            spacing = np.where(n > 1, np.maximum(major - width, 0) / np.maximum(n - 1, 1), 0.0)
    axis_uv = U[:, :, 0] / s
    return major, width, n, spacing, axis_uv


def anisotropic(t, levels, uv, duv_dx, duv_dy, mode):
    """kernels/texture/texture.h texture_anisotropic in float64 (derivatives already transformed)."""
    major, width, n, spacing, axis_uv = aniso_footprint(t, duv_dx, duv_dy)
    out = np.zeros((len(uv), 4))
    bad = ~(np.isfinite(major) & (major > 0))
    if bad.any():                                     # one trilinear probe at lod log2(major)
        with np.errstate(divide="ignore", invalid="ignore"):
            out[bad] = trilinear(levels, uv[bad], np.log2(major[bad]), mode)
    good = ~bad
    if not good.any():
        return out
    lod = np.log2(width[good])
    acc, wsum = np.zeros((good.sum(), 4)), np.zeros(good.sum())
    ng = n[good]
    for k in range(int(ng.max())):
        on = k < ng
        tk = (k - 0.5 * (ng - 1)) * spacing[good]
        w = np.where(on, np.exp(-2.0 * (2.0 * tk / major[good]) ** 2), 0.0)
        p = uv[good] + tk[:, None] * axis_uv[good]
        acc += w[:, None] * trilinear(levels, p, lod, mode)
        wsum += w
    out[good] = acc / wsum[:, None]
    return out


def scene_hits(scene, width, height):
    """(compiled scene, origins, directions, t, b1, b2, triangle) of the float64 closest hits
    of the pixel-centre camera rays with the scene's compiled triangles (-1: miss)."""
    cs = compile_scene(scene)
    p0, p1, p2 = (cs.tri_verts[k].astype(np.float64) for k in ("p0", "p1", "p2"))
    org, d = camera_rays(scene, width, height)
    t, b1, b2, tri = intersect(org, d, p0, p1, p2)
    return cs, org, d, t, b1, b2, tri


# Adaptive sampling's stopping rule (texray.renderer.adaptive), float64: what the device's
# float32 decision (kernels/core/adaptive.h, stages/adaptive.cl) is held to.
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])     # Rec. 709


def adaptive_standard_error(sum_rgb, sum_y2, n):
    """(mean luminance, standard error of that mean) per pixel from the accumulated sums of
    n samples (n >= 2)."""
    rgb = np.asarray(sum_rgb, np.float64)
    sum_y = rgb @ LUMINANCE
    n = np.asarray(n, np.float64)
    mean = sum_y / n
    var = np.maximum(np.asarray(sum_y2, np.float64) - sum_y * mean, 0.0) / np.maximum(n - 1, 1)
    return mean, np.sqrt(var / n)


def adaptive_unconverged(mean, se, threshold):
    """The pixels whose standard error is above the threshold (relative, with the absolute
    floor below a mean of FLOOR)."""
    from texray.renderer.adaptive import FLOOR
    return se > threshold * np.maximum(mean, FLOOR)


def adaptive_dilate(open_, rows, width, y0=0):
    """The (rows * width,) pixels of a tile of ``rows`` rows from image row ``y0`` that keep
    sampling, from its mask of unconverged pixels: those with an unconverged pixel in their
    3x3 neighbourhood within their block of BLOCK_ROWS image rows and within the tile."""
    from texray.renderer.adaptive import BLOCK_ROWS
    open_ = np.asarray(open_, bool).reshape(rows, width)
    y = y0 + np.arange(rows)
    first, last = (y % BLOCK_ROWS == 0)[:, None], (y % BLOCK_ROWS == BLOCK_ROWS - 1)[:, None]
    p = np.pad(open_, ((0, 0), (1, 1)))
    across = p[:, :-2] | p[:, 1:-1] | p[:, 2:]              # the row's own 1x3 neighbourhood
    grown = across.copy()
    grown[1:] |= across[:-1] & ~first[1:]                    # the row above, within the block
    grown[:-1] |= across[1:] & ~last[:-1]                    # the row below, within the block
    return grown.ravel()
