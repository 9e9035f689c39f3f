"""float64 numpy references for the analytic primitives of kernels/geometry/sphere.h,
cylinder.h and quad.h, vectorized over rays.

Each ``*_intersect`` takes ray origins and directions of shape (n, 3) (the
float32 values the device sees, widened to float64) and returns a dict of
arrays: ``hit`` (bool), ``t`` (inf where missed) and, where hit, the same
geometry the device's ``*_geom`` produces: ``p``, ``ng``, ``dpdu``, ``dpdv``,
``uv`` (texture coordinates), plus ``param`` ((u, v) of the bilinear patch) for
quads. Conventions are those of the kernels' header comments:

* sphere: frame x = axis_x, z = axis_z, y = z x x; uv = (phi / 2pi, 1 - theta / pi),
  dpdu = 2pi dP/dphi, dpdv = -pi dP/dtheta;
* cylinder: uv = ((theta - theta_min) / (theta_max - theta_min), (z - z_min) / (z_max - z_min)),
  theta - theta_min reduced modulo 2pi into [0, 2pi);
* quad: P(u, v) = (1-u)(1-v) P0 + u(1-v) P1 + uv P2 + (1-u)v P3, texture uv bilinear in
  the per-vertex uvs, dP/d(texture uv) = [dP/du dP/dv] J^-1.

``grow`` (a fraction of the primitive's size) enlarges (> 0) or shrinks (< 0) the
primitive: radius, z and theta ranges, or the (u, v) domain; the tests use it to
set aside rays that pass within a hair of a quad's edge.
"""
from __future__ import annotations

import numpy as np

TWO_PI = 2.0 * np.pi


def _f64(a):
    return np.asarray(a, dtype=np.float64)


def _unit(v):
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        return v / n


def _empty(n):
    nan3 = np.full((n, 3), np.nan)
    return {"hit": np.zeros(n, bool), "t": np.full(n, np.inf), "p": nan3.copy(), "ng": nan3.copy(),
            "dpdu": nan3.copy(), "dpdv": nan3.copy(), "uv": np.full((n, 2), np.nan),
            "param": np.full((n, 2), np.nan)}


def _quadratic_roots(a, half_b, c, disc):
    """Roots of a t^2 + 2 half_b t + c = 0, given disc = half_b^2 - a c >= 0, by the
    stable pair c/q, q/a (NaN where undefined); returned sorted."""
    with np.errstate(invalid="ignore", divide="ignore"):
        q = -(half_b + np.copysign(np.sqrt(np.maximum(disc, 0.0)), half_b))
        r0, r1 = c / q, q / a
    return np.fmin(r0, r1), np.fmax(r0, r1)


# --- sphere -----------------------------------------------------------------

def frame(axis_x, axis_z):
    """The frame (x, y = z x x, z) of a primitive's float32 axes, in float64."""
    ax, az = _f64(axis_x), _f64(axis_z)
    return ax, np.cross(az, ax), az


def sphere_uv_of_point(local, axis_x, axis_z):
    """uv, dpdu, dpdv, theta, phi of points given relative to the centre (on the sphere).
    Exactly at a pole dpdu is 0 here; the device's fallback there is tested on its own."""
    ax, ay, az = frame(axis_x, axis_z)
    x, y, z = local @ ax, local @ ay, local @ az
    rho = np.hypot(x, y)
    theta = np.arctan2(rho, z)
    phi = np.mod(np.arctan2(y, x), TWO_PI)
    with np.errstate(invalid="ignore", divide="ignore"):
        cphi, sphi = np.where(rho > 0, x / rho, 1.0), np.where(rho > 0, y / rho, 0.0)
    dp_dphi = x[:, None] * ay - y[:, None] * ax
    dp_dtheta = z[:, None] * (cphi[:, None] * ax + sphi[:, None] * ay) - rho[:, None] * az
    uv = np.stack([phi / TWO_PI, 1.0 - theta / np.pi], axis=-1)
    return uv, TWO_PI * dp_dphi, -np.pi * dp_dtheta, theta, phi


def sphere_intersect(center, radius, axis_x, axis_z, org, dirs, tmin=0.0, tmax=np.inf, grow=0.0):
    """Nearest hit of each ray with the sphere, t in (tmin, tmax)."""
    c, r = _f64(center), float(radius) * (1.0 + grow)
    o, d = _f64(org), _f64(dirs)
    n = len(o)
    out = _empty(n)
    f = o - c
    a = np.einsum("ij,ij->i", d, d)
    b = np.einsum("ij,ij->i", f, d)
    w = np.cross(f, d)
    with np.errstate(invalid="ignore", divide="ignore"):
        disc = a * (r * r - np.einsum("ij,ij->i", w, w) / a)      # = b^2 - a c, without cancellation
    cc = np.einsum("ij,ij->i", f, f) - r * r
    t0, t1 = _quadratic_roots(a, b, cc, disc)
    ok = (disc >= 0) & (a > 0) & (r > 0)
    t = np.where(ok & (t0 > tmin) & (t0 < tmax), t0, np.where(ok & (t1 > tmin) & (t1 < tmax), t1, np.inf))
    hit = np.isfinite(t)
    out["hit"], out["t"] = hit, t
    if hit.any():
        local = f[hit] + t[hit, None] * d[hit]
        local *= r / np.linalg.norm(local, axis=1, keepdims=True)
        uv, dpdu, dpdv, _, _ = sphere_uv_of_point(local, axis_x, axis_z)
        out["p"][hit] = c + local
        out["ng"][hit] = local / r
        out["uv"][hit], out["dpdu"][hit], out["dpdv"][hit] = uv, dpdu, dpdv
    return out


# --- cylinder ---------------------------------------------------------------

def cylinder_theta_rel(x, y, theta_min):
    return np.mod(np.arctan2(y, x) - theta_min, TWO_PI)


def cylinder_intersect(origin, radius, axis_x, axis_z, z_min, z_max, theta_min, theta_max,
                       org, dirs, tmin=0.0, tmax=np.inf, grow=0.0):
    """Nearest hit of each ray with the partial open cylinder, t in (tmin, tmax).
    ``grow`` scales the radius by (1 + grow) and widens each range by grow times its length."""
    o0 = _f64(origin)
    ax, ay, az = frame(axis_x, axis_z)
    r = float(radius) * (1.0 + grow)
    zr, span = float(z_max) - float(z_min), float(theta_max) - float(theta_min)
    z_lo, z_hi = float(z_min) - grow * zr, float(z_max) + grow * zr
    th_lo, th_span = float(theta_min) - grow * span, span * (1.0 + 2.0 * grow)
    o, d = _f64(org), _f64(dirs)
    n = len(o)
    out = _empty(n)
    f = o - o0
    fl = np.stack([f @ ax, f @ ay, f @ az], axis=-1)
    dl = np.stack([d @ ax, d @ ay, d @ az], axis=-1)
    a = dl[:, 0] ** 2 + dl[:, 1] ** 2
    b = fl[:, 0] * dl[:, 0] + fl[:, 1] * dl[:, 1]
    w = fl[:, 0] * dl[:, 1] - fl[:, 1] * dl[:, 0]
    with np.errstate(invalid="ignore", divide="ignore"):
        disc = a * (r * r - w * w / a)
    cc = fl[:, 0] ** 2 + fl[:, 1] ** 2 - r * r
    roots = _quadratic_roots(a, b, cc, disc)
    valid = (disc >= 0) & (a > 0) & (r > 0) & (zr > 0) & (span > 0)
    t = np.full(n, np.inf)
    for root in roots[::-1]:          # the nearer root last, so that it wins
        with np.errstate(invalid="ignore"):
            pt = fl + root[:, None] * dl
            rel = cylinder_theta_rel(pt[:, 0], pt[:, 1], th_lo)
            ok = (valid & (root > tmin) & (root < tmax) & (pt[:, 2] >= z_lo) & (pt[:, 2] <= z_hi)
                  & (rel <= th_span))
        t = np.where(ok, root, t)
    hit = np.isfinite(t)
    out["hit"], out["t"] = hit, t
    if hit.any():
        pt = fl[hit] + t[hit, None] * dl[hit]
        rho = np.hypot(pt[:, 0], pt[:, 1])
        x, y, z = pt[:, 0] * r / rho, pt[:, 1] * r / rho, pt[:, 2]
        radial = x[:, None] * ax + y[:, None] * ay
        out["p"][hit] = o0 + radial + z[:, None] * az
        out["ng"][hit] = radial / r
        rel = cylinder_theta_rel(x, y, float(theta_min))
        out["uv"][hit] = np.stack([rel / span, (z - float(z_min)) / zr], axis=-1)
        out["dpdu"][hit] = span * (x[:, None] * ay - y[:, None] * ax)
        out["dpdv"][hit] = np.broadcast_to(zr * az, (hit.sum(), 3))
    return out


# --- bilinear quad ----------------------------------------------------------

def quad_point(P, u, v):
    """P(u, v) and its parametric derivatives, for vertices P (4, 3)."""
    P = _f64(P)
    u, v = _f64(u)[..., None], _f64(v)[..., None]
    p = (1 - u) * (1 - v) * P[0] + u * (1 - v) * P[1] + u * v * P[2] + (1 - u) * v * P[3]
    pu = (1 - v) * (P[1] - P[0]) + v * (P[2] - P[3])
    pv = (1 - u) * (P[3] - P[0]) + u * (P[2] - P[1])
    return p, pu, pv


def quad_texture(P, tex_uv, u, v):
    """Texture uv and dP/d(texture uv) at bilinear parameters (u, v); tex_uv is (4, 2).
    Where the texture Jacobian is singular the derivatives stay parametric."""
    T = _f64(tex_uv).reshape(4, 2)
    _, pu, pv = quad_point(P, u, v)
    uu, vv = _f64(u)[..., None], _f64(v)[..., None]
    uv = (1 - uu) * (1 - vv) * T[0] + uu * (1 - vv) * T[1] + uu * vv * T[2] + (1 - uu) * vv * T[3]
    tu = (1 - vv) * (T[1] - T[0]) + vv * (T[2] - T[3])
    tv = (1 - uu) * (T[3] - T[0]) + uu * (T[2] - T[1])
    det = tu[:, 0] * tv[:, 1] - tv[:, 0] * tu[:, 1]
    size = np.abs(tu[:, 0] * tv[:, 1]) + np.abs(tv[:, 0] * tu[:, 1])
    regular = np.abs(det) > 2.0 ** -16 * size
    with np.errstate(invalid="ignore", divide="ignore"):
        inv = np.where(regular, 1.0 / det, 0.0)[:, None]
    dpdu = np.where(regular[:, None], (tv[:, 1:2] * pu - tu[:, 1:2] * pv) * inv, pu)
    dpdv = np.where(regular[:, None], (tu[:, 0:1] * pv - tv[:, 0:1] * pu) * inv, pv)
    return uv, dpdu, dpdv


def _perpendicular_planes(d):
    """Two unit normals n1, n2 of planes that contain each ray direction d."""
    dn = _unit(d)
    k = np.argmin(np.abs(dn), axis=1)
    e = np.eye(3)[k]
    n1 = _unit(np.cross(dn, e))
    return n1, np.cross(dn, n1)


def quad_intersect(P, org, dirs, tmin=0.0, tmax=np.inf, grow=0.0, tex_uv=None, newton_steps=3):
    """Nearest hit of each ray with the bilinear patch P (4, 3), t in (tmin, tmax),
    (u, v) in [-grow, 1 + grow]^2.

    Independent of Reshetov's formulation (the device's): the ray is the
    intersection of two planes n_k . (x - o) = 0; P(u, v) in both gives two
    bilinear equations, and eliminating v a quadratic in u (Kajiya's method, as
    in Ramsey, Potter, Hansen, "Ray Bilinear Patch Intersections", JGT 9(3),
    2004). Each root is then polished by Newton's method on P(u, v) - o - t d = 0.
    """
    P = _f64(P)
    o, d = _f64(org), _f64(dirs)
    n = len(o)
    out = _empty(n)
    e1, e3, qq = P[1] - P[0], P[3] - P[0], P[0] - P[1] + P[2] - P[3]
    n1, n2 = _perpendicular_planes(d)
    rel0 = P[0] - o
    D1, D2 = np.einsum("ij,ij->i", n1, rel0), np.einsum("ij,ij->i", n2, rel0)
    B1, B2, C1, C2, A1, A2 = n1 @ e1, n2 @ e1, n1 @ e3, n2 @ e3, n1 @ qq, n2 @ qq
    alpha = B1 * A2 - B2 * A1
    beta = D1 * A2 + B1 * C2 - D2 * A1 - B2 * C1
    gamma = D1 * C2 - D2 * C1
    disc = beta * beta - 4 * alpha * gamma
    with np.errstate(invalid="ignore", divide="ignore"):
        q = -0.5 * (beta + np.copysign(np.sqrt(np.maximum(disc, 0.0)), beta))
        roots = (q / alpha, gamma / q)
    lo, hi = -grow, 1.0 + grow
    best_t = np.full(n, np.inf)
    best_u, best_v = np.full(n, np.nan), np.full(n, np.nan)
    a = np.einsum("ij,ij->i", d, d)
    for u in roots:
        with np.errstate(invalid="ignore", divide="ignore"):
            den1, den2 = C1 + A1 * u, C2 + A2 * u
            v = np.where(np.abs(den1) >= np.abs(den2), -(D1 + B1 * u) / den1, -(D2 + B2 * u) / den2)
            p, _, _ = quad_point(P, u, v)
            t = np.einsum("ij,ij->i", p - o, d) / a
            for _ in range(newton_steps):
                p, pu, pv = quad_point(P, u, v)
                res = p - o - t[:, None] * d
                jac = np.stack([pu, pv, -d], axis=-1)
                good = np.isfinite(jac).all(axis=(1, 2)) & np.isfinite(res).all(axis=1)
                step = np.zeros((n, 3))
                if good.any():
                    jg = jac[good]
                    ok = np.abs(np.linalg.det(jg)) > 0
                    sg = np.zeros((good.sum(), 3))
                    sg[ok] = np.linalg.solve(jg[ok], res[good][ok][..., None])[..., 0]
                    step[good] = sg
                u, v, t = u - step[:, 0], v - step[:, 1], t - step[:, 2]
            ok = ((disc >= 0) & (u >= lo) & (u <= hi) & (v >= lo) & (v <= hi)
                  & (t > tmin) & (t < tmax) & (t < best_t))
        best_t = np.where(ok, t, best_t)
        best_u, best_v = np.where(ok, u, best_u), np.where(ok, v, best_v)
    hit = np.isfinite(best_t)
    out["hit"], out["t"] = hit, best_t
    if hit.any():
        u, v = best_u[hit], best_v[hit]
        p, pu, pv = quad_point(P, u, v)
        out["p"][hit], out["param"][hit] = p, np.stack([u, v], axis=-1)
        out["ng"][hit] = _unit(np.cross(pu, pv))
        tex = tex_uv if tex_uv is not None else [0, 0, 1, 0, 1, 1, 0, 1]
        out["uv"][hit], out["dpdu"][hit], out["dpdv"][hit] = quad_texture(P, tex, u, v)
    return out
