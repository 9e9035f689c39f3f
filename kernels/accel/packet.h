#line 2 "accel/packet.h"
/* Packets: TX_PACKET (8 or 16) rays traced together, one per vector lane -- a pixel's
 * samples' camera rays (closest hit) and their shadow rays toward one light (any hit,
 * shading/shadow.h; stages/fused.cl), which start within one pixel's footprint, so they
 * enter nearly the same nodes.
 *
 * The scalar traversals (accel/bvh.h) test one ray against a node's four boxes as a
 * float4; here each of the four boxes is tested against every ray of the packet as one
 * floatN, and a leaf's triangles one at a time against the whole packet, so that the node
 * reads, the stack and the loop are shared by N rays and the arithmetic runs N wide.
 *
 * Every lane computes its box and triangle tests with the scalar code's arithmetic (the
 * same formulas in the same order, FP_CONTRACT OFF: box_entry_packet is box4_entry's,
 * the triangle tests share geometry/triangle.h's macros with triangle_intersect4), and
 * the stack carries each entry's lane mask (the lanes that entered that box). So:
 * - any hit: a lane is tested against exactly the boxes and leaves that bvh_any tests for
 *   its ray, in the same order, and leaves the packet at its first hit: the same answers,
 *   bit for bit;
 * - closest hit: the packet visits children nearest first by its nearest lane, not by each
 *   lane's own order; triangles tie on t by their index (triangle_intersect4), so a lane
 *   ends with bvh_closest's hit bit for bit, except where two triangles' hits lie within
 *   the box tests' rounding of each other (a ray through a shared vertex or edge): then the
 *   order may decide which of the two (at the same t to within an ulp or two) is kept.
 * Quads and spheres are tested one at a time against the whole packet too (geometry/
 * quad_packet.h, sphere_packet.h: the scalar tests' arithmetic per lane, so the same hits
 * bit for bit). Leaves of the other kinds (cylinders, displaced shapes, instances) are tested lane by lane by
 * the scalar leaf_hit (geometry/dispatch.h); closest-hit packets leave instanced scenes (hits carry the instance) to the
 * scalar traversal. The host compiles packets in only where they measured faster
 * (texray.device.features.packet_width).
 * A packet whose lanes share their direction's sign along some axis tests a node's four
 * boxes first against its beam (beam_box4: bounds of its lanes, one float4 test) and each box
 * the beam may enter lane by lane: the same lanes enter the same boxes. */
#ifndef TEXRAY_PACKET_H
#define TEXRAY_PACKET_H
#include "accel/bvh.h"

/* A vector from an array of the packet's lanes: PLOAD, one vector load, or TX_LANES, a vector
 * built of TX_PACKET scalar loads (LLVM's insertelement chains). PLOAD wherever it costs no
 * time: TX_LANES made LLVM's InstCombine and code generation work through a chain per vector
 * at every cold build (PLOAD in packet_setup, the camera and tracer lanes and the sphere,
 * quad and triangle packets' gathers: 11% fewer instructions in the mixed scene's cold build,
 * callgrind). TX_LANES is left where a hot path has just stored the lanes one by one
 * (the leaves' lane loops, the surface's lane masks), which a wide load would wait for. */
#if TX_PACKET == 16
typedef float16 pfloat;
typedef int16 pint;
typedef uint16 puint;
#define as_pint as_int16
#define as_puint as_uint16
#define as_pfloat as_float16
#define TX_PACKET_EXACT_EDGES(U, V, W, ax, ay, bx, by, cx, cy) TX_WOOP_EXACT_EDGES(16, U, V, W, ax, ay, bx, by, cx, cy)
#define TX_LANES(p) (p)[0], (p)[1], (p)[2], (p)[3], (p)[4], (p)[5], (p)[6], (p)[7], \
                  (p)[8], (p)[9], (p)[10], (p)[11], (p)[12], (p)[13], (p)[14], (p)[15]
#define PSTORE(v, p) vstore16(v, 0, p)
#define PLOAD(p) vload16(0, p)
#elif TX_PACKET == 8
typedef float8 pfloat;
typedef int8 pint;
typedef uint8 puint;
#define as_pint as_int8
#define as_puint as_uint8
#define as_pfloat as_float8
#define TX_PACKET_EXACT_EDGES(U, V, W, ax, ay, bx, by, cx, cy) TX_WOOP_EXACT_EDGES(8, U, V, W, ax, ay, bx, by, cx, cy)
#define TX_LANES(p) (p)[0], (p)[1], (p)[2], (p)[3], (p)[4], (p)[5], (p)[6], (p)[7]
#define PSTORE(v, p) vstore8(v, 0, p)
#define PLOAD(p) vload8(0, p)
#else
#error "TX_PACKET must be 8 or 16"
#endif

/* The packet's rays org + t dir, t in (tmin, tmax), one per lane, with what the scalar
 * traversal derives once per ray: safe_inverse of the direction, its signs, the parallel
 * flag and woop_setup's shear rows; and the rays as arrays, for the lane-by-lane paths.
 * The caller sets every lane (packet_set_lane; a lane it does not trace with any valid ray,
 * masked out) and calls packet_setup. */
typedef struct {
    float org[3][TX_PACKET], dir[3][TX_PACKET], range[2][TX_PACKET];
    pfloat tmin, tmax;
    pfloat ox, oy, oz;
    pfloat dx, dy, dz;
    pfloat ivx, ivy, ivz;
    pint nx, ny, nz, par;
    pfloat rxx, rxy, rxz, ryx, ryy, ryz, rzx, rzy, rzz;
    /* Where every traced lane has the same shear axes (kx, ky, kz; nearly every packet of one
     * pixel's camera rays or of shadow rays toward one light): uniform = 1, the axes, the
     * origins' coordinates along them and the shear factors sx, sy, sz per lane. */
    int uniform, kx, ky, kz;
    pfloat okx, oky, okz, sx, sy, sz;
    /* The traced lanes' direction signs (bit 0: x < 0, 1: y, 2: z) along the axes where they
     * all share them, and the axes where they do not (mixed; none in nearly every packet of
     * camera or shadow rays): the beam test needs them, and at 16 lanes (TX_PACKET_OCTANT)
     * box_entry_packet picks each slab's near and far planes once for a packet without mixed
     * axes, not lane by lane: there a lane-by-lane pick takes two vector selects per plane,
     * and tools/ab.py measured 0.97 of the textured meshes' frame; at 8 lanes that pick cost
     * more than it saved (globe 1.03, bumped brick wall 1.02). */
    int signs, mixed;
    /* Whether the shear fields above (uniform .. sz, rxx .. rzz) are set: packet_setup leaves
     * them to packet_shear, which the first triangle leaf the packet reaches calls (most
     * shadow packets and the sky's camera packets reach none; the shear was a third of
     * packet_setup's time); `active`, the lanes packet_setup was given, decides uniform. */
    int sheared;
    pint active;
    /* The beam (beam_box4): where `beam` is 1 -- the active lanes share their direction's sign
     * along at least one axis and none is parallel to an axis -- the bounds over the active
     * lanes of their origins and tmin (bmin: the smallest, .w tmin; bmax: the largest, .w
     * tmax) and of the inverse directions (ivmin, ivmax). */
    int beam;
    float4 bmin, bmax, ivmin, ivmax;
} PacketRay;
#define TX_PACKET_OCTANT (TX_PACKET == 16)


/* Lane j of the packet: the ray org + t dir, t in (tmin, tmax). */
static inline void packet_set_lane(PacketRay* r, uint j, float3 org, float3 dir, float tmin, float tmax)
{
    r->org[0][j] = org.x; r->org[1][j] = org.y; r->org[2][j] = org.z;
    r->dir[0][j] = dir.x; r->dir[1][j] = dir.y; r->dir[2][j] = dir.z;
    r->range[0][j] = tmin; r->range[1][j] = tmax;
}

/* c ? a : b lane by lane for a lane mask c (-1 or 0 per lane), as bit operations: Oclgrind
 * 21.10 evaluates ?: on int16 vectors wrongly (true lanes of `c ? (int16)(1) : (int16)(2)`
 * read 255), and LLVM makes the same blend of either form. */
#define PSEL_I(c, a, b) (((c) & (a)) | (~(c) & (b)))
#define PSEL_F(c, a, b) as_pfloat(PSEL_I(c, as_pint(a), as_pint(b)))
/* TX_MAX and TX_MIN (core/common.h), the same choice per lane (NaN: the second operand). */
#define PMAX(a, b) PSEL_F((a) > (b), a, b)
#define PMIN(a, b) PSEL_F((a) < (b), a, b)

/* safe_inverse (core/common.h) lane by lane: +-2^100 with x's sign bit (copysign). */
static inline pfloat safe_inverse_p(pfloat x)
{
    pfloat big = as_pfloat((as_pint(x) & (pint)(0x80000000)) | (pint)(as_int(TX_PARALLEL_INV)));
    return PSEL_F(fabs(x) < 7.888609e-31f, big, 1.0f / x);
}

/* packet_min: the smallest lane of v (the packet's nearest entry into a box: the traversal's
 * order); packet_max: the largest (TX_MIN, TX_MAX halving the vector); packet_min_int: the
 * smallest lane of an int vector (its lane selects as bit operations: PSEL_I). */
#if TX_PACKET == 16
#define TX_PACKET_REDUCE(name, op, last, T) static inline T name(T##16 v) \
    { T##8 v8 = op(v.lo, v.hi); T##4 v4 = op(v8.lo, v8.hi); T##2 v2 = op(v4.lo, v4.hi); return last(v2.x, v2.y); }
#else
#define TX_PACKET_REDUCE(name, op, last, T) static inline T name(T##8 v) \
    { T##4 v4 = op(v.lo, v.hi); T##2 v2 = op(v4.lo, v4.hi); return last(v2.x, v2.y); }
#endif
#define TX_IMIN(a, b) PSEL_I((a) < (b), a, b)
TX_PACKET_REDUCE(packet_min, TX_MIN, TX_MIN, float)
TX_PACKET_REDUCE(packet_max, TX_MAX, TX_MAX, float)
TX_PACKET_REDUCE(packet_min_int, TX_IMIN, TX_MIN, int)
#undef TX_IMIN
#undef TX_PACKET_REDUCE

/* The component of v along axis k (0, 1, 2) of a packet's uniform shear. */
#define TX_PAXIS(k, x, y, z) ((k) == 0 ? (x) : ((k) == 1 ? (y) : (z)))

/* What the scalar traversal derives per ray, lane by lane, with its arithmetic: safe_inverse
 * of the direction, its signs and the parallel flag; woop_setup's shear (packet_shear) is
 * left to the first triangle leaf the packet reaches. `active`: the lanes to be traced,
 * whose axes decide whether the packet's shear is uniform (triangle_packet). */
inline void packet_setup(PacketRay* r, pint active)
{
    pfloat dx = PLOAD(r->dir[0]), dy = PLOAD(r->dir[1]), dz = PLOAD(r->dir[2]);
    r->tmin = PLOAD(r->range[0]); r->tmax = PLOAD(r->range[1]);
    r->ox = PLOAD(r->org[0]); r->oy = PLOAD(r->org[1]); r->oz = PLOAD(r->org[2]);
    r->dx = dx; r->dy = dy; r->dz = dz;
    r->ivx = safe_inverse_p(dx); r->ivy = safe_inverse_p(dy); r->ivz = safe_inverse_p(dz);
    r->par = (fabs(r->ivx) >= TX_PARALLEL_INV) | (fabs(r->ivy) >= TX_PARALLEL_INV) | (fabs(r->ivz) >= TX_PARALLEL_INV);
    r->nx = r->ivx < 0.0f; r->ny = r->ivy < 0.0f; r->nz = r->ivz < 0.0f;
    int sx = any(active & r->nx), sy = any(active & r->ny), sz = any(active & r->nz);
    int mx = sx && any(active & ~r->nx), my = sy && any(active & ~r->ny), mz = sz && any(active & ~r->nz);
    r->signs = sx | sy << 1 | sz << 2;
    r->mixed = mx | my << 1 | mz << 2;
    r->uniform = 0;
    r->sheared = 0;
    r->active = active;
    /* the beam, at both widths: tools/ab.py with TEXRAY_PACKET=8 on both sides measured the
     * textured meshes 0.876, globe 0.994, brick wall 0.971, and the bench's rays (8-lane
     * Tracer packets) 1.05-1.18 times the primary and 1.09-1.22 times the shadow rate */
    r->beam = r->mixed != 7 && !any(active & r->par);
    if (r->beam) {
        pfloat inf = (pfloat)(INFINITY), ninf = (pfloat)(-INFINITY);
#define TX_BMIN(v) packet_min(PSEL_F(active, v, inf))
#define TX_BMAX(v) packet_max(PSEL_F(active, v, ninf))
        r->bmin = (float4)(TX_BMIN(r->ox), TX_BMIN(r->oy), TX_BMIN(r->oz), TX_BMIN(r->tmin));
        r->bmax = (float4)(TX_BMAX(r->ox), TX_BMAX(r->oy), TX_BMAX(r->oz), TX_BMAX(r->tmax));
        r->ivmin = (float4)(TX_BMIN(r->ivx), TX_BMIN(r->ivy), TX_BMIN(r->ivz), 0.0f);
        r->ivmax = (float4)(TX_BMAX(r->ivx), TX_BMAX(r->ivy), TX_BMAX(r->ivz), 0.0f);
#undef TX_BMIN
#undef TX_BMAX
    }
}

/* woop_setup lane by lane for the packet's lanes: its axes (woop_axes) as lane masks -- kz
 * == i, and kx, ky from it, swapped where d[kz] < 0 -- and its shear rows unit3(k) - s
 * unit3(kz), s = d[k] / d[kz] (triangle_packet's only: a scene of spheres or quads spent 4-8%
 * of its frame on them). The masks are combined with bit operations only: a select among
 * constant int vectors is what Oclgrind 21.10 miscomputes (woop_axes per lane in scalar
 * code measured 12% of a textured-mesh frame). Once per packet, from the first triangle
 * leaf it reaches (packet_shear_once). */
inline void packet_shear(PacketRay* r)
{
    r->sheared = 1;
    pint active = r->active;
    pfloat dx = r->dx, dy = r->dy, dz = r->dz;
    pfloat adx = fabs(dx), ady = fabs(dy), adz = fabs(dz);
    pint cxy = adx > ady, cxz = adx > adz, cyz = ady > adz;
    pint z0 = cxy & cxz, z1 = ~cxy & cyz, z2 = ~(z0 | z1);            /* kz == 0, 1, 2 */
    /* kx = kz == 2 ? 0 : kz + 1 and ky = kx == 2 ? 0 : kx + 1, as masks */
    pint x0 = z2, x1 = z0, x2 = z1, y0 = z1, y1 = z2, y2 = z0;
    pfloat dkz = PSEL_F(z0, dx, PSEL_F(z1, dy, dz));
    pint neg = dkz < 0.0f;                                              /* keep the winding: swap kx, ky */
    pint X0 = PSEL_I(neg, y0, x0), X1 = PSEL_I(neg, y1, x1), X2 = PSEL_I(neg, y2, x2);
    pint Y0 = PSEL_I(neg, x0, y0), Y1 = PSEL_I(neg, x1, y1), Y2 = PSEL_I(neg, x2, y2);
    pfloat sx = PSEL_F(X0, dx, PSEL_F(X1, dy, dz)) / dkz, sy = PSEL_F(Y0, dx, PSEL_F(Y1, dy, dz)) / dkz;
    pfloat sz = 1.0f / dkz;
    /* the axes as numbers 0..2 per lane, packed kx | ky << 2 | kz << 4; uniform where every
     * active lane has the same (then triangle_packet needs no rows) */
    pint kxi = (X1 & 1) | (X2 & 2), kyi = (Y1 & 1) | (Y2 & 2), kzi = (z1 & 1) | (z2 & 2);
    pint code = kxi | (kyi << 2) | (kzi << 4);
    /* the smallest active lane's code (0 .. 42; 63 where no lane is active) as a vector
     * reduction: where every active lane has one code, that code (a scalar loop over the
     * stored lanes for the first active one was a fifth of this function's instructions) */
    int c0 = packet_min_int(PSEL_I(active, code, (pint)(63)));
    r->uniform = c0 != 63 && !any(active & (code != (pint)(c0)));
    if (r->uniform) {
        r->kx = c0 & 3; r->ky = (c0 >> 2) & 3; r->kz = c0 >> 4;
        r->okx = TX_PAXIS(r->kx, r->ox, r->oy, r->oz);
        r->oky = TX_PAXIS(r->ky, r->ox, r->oy, r->oz);
        r->okz = TX_PAXIS(r->kz, r->ox, r->oy, r->oz);
        r->sx = sx; r->sy = sy; r->sz = sz;
        return;
    }
    pfloat one = (pfloat)(1.0f), zero = (pfloat)(0.0f);
    pfloat uzx = PSEL_F(z0, one, zero), uzy = PSEL_F(z1, one, zero), uzz = PSEL_F(z2, one, zero);
    r->rxx = PSEL_F(X0, one, zero) - sx * uzx; r->rxy = PSEL_F(X1, one, zero) - sx * uzy;
    r->rxz = PSEL_F(X2, one, zero) - sx * uzz;
    r->ryx = PSEL_F(Y0, one, zero) - sy * uzx; r->ryy = PSEL_F(Y1, one, zero) - sy * uzy;
    r->ryz = PSEL_F(Y2, one, zero) - sy * uzz;
    r->rzx = sz * uzx; r->rzy = sz * uzy; r->rzz = sz * uzz;
}

/* The packet's shear, set where it is not yet (packet_shear). */
#define packet_shear_once(r) do { if (!(r)->sheared) packet_shear(r); } while (0)

#if TX_QUADS
#include "geometry/quad_packet.h"     /* quad_intersect_packet: needs PacketRay and the lane selects */
#endif
#if TX_SPHERES
#include "geometry/sphere_packet.h"   /* sphere_intersect_packet */
#endif
/* A packet's triangle hits' geometry as one vector computation: on PoCL only
 * (TX_TRI_GEOM_PACKET, geometry/dispatch.h; geometry/triangle_packet.h says why). */
#if TX_TRI_GEOM_PACKET
#include "geometry/triangle_packet.h"
#endif

/* Whether any lane of the packet can enter each of a wide node's four boxes (the beam test,
 * interval arithmetic over the lanes, the packet culling of Wald, Boulos and Shirley 2007): -1 where one
 * may, 0 where none can. Each lane's box4_entry arithmetic -- (plane - o) * iv per slab, the
 * largest near distance and tmin against the smallest far distance scaled by 1 + 2 gamma(3)
 * and tmax, and the far distance above 0 -- is a chain of operations each monotone in its
 * inputs, and float rounding is monotone too, so the same operations on the bounds of the
 * lanes' origins, inverse directions and intervals (PacketRay.bmin .. ivmax) bound every lane's
 * near distance from below and far distance from above: a box the beam misses, every lane
 * misses. (The products' bounds take both ends of the inverse directions' interval: their
 * signs are the packet's, the differences' signs are not known.) One float4 test for
 * the four boxes, in place of four lane-by-lane tests where no lane enters. The lanes that
 * do enter are still found by box_entry_packet, so every answer is the same. */
static inline int4 beam_box4(const PacketRay* r, float4 lox, float4 hix, float4 loy, float4 hiy, float4 loz, float4 hiz,
                             float tmax)
{
    int o = r->signs, mixed = r->mixed;
    float4 bmin = r->bmin, bmax = r->bmax, ivmin = r->ivmin, ivmax = r->ivmax;
    /* per axis: the near plane's difference bound (the largest origin for a positive
     * direction, the smallest for a negative one: the smallest product either way) and the
     * far plane's (the other end); an axis whose lanes' signs are mixed bounds nothing
     * (-inf, +inf: its lanes use either plane), the others still do */
#define TX_BEAM_AXIS(bit, lo, hi, c, tn, tf) do { \
        float4 nd_ = (o & (bit)) ? (hi) - (float4)(bmin.c) : (lo) - (float4)(bmax.c); \
        float4 fd_ = (o & (bit)) ? (lo) - (float4)(bmax.c) : (hi) - (float4)(bmin.c); \
        tn = TX_MIN(nd_ * ivmin.c, nd_ * ivmax.c); \
        tf = TX_MAX(fd_ * ivmin.c, fd_ * ivmax.c); \
        if (mixed & (bit)) { tn = (float4)(-INFINITY); tf = (float4)(INFINITY); } \
    } while (0)
    float4 tnx, tfx, tny, tfy, tnz, tfz;
    TX_BEAM_AXIS(1, lox, hix, x, tnx, tfx);
    TX_BEAM_AXIS(2, loy, hiy, y, tny, tfy);
    TX_BEAM_AXIS(4, loz, hiz, z, tnz, tfz);
#undef TX_BEAM_AXIS
    float4 tn = TX_MAX(TX_MAX(tnx, tny), TX_MAX(tnz, (float4)(bmin.w)));
    float4 tf = TX_MIN(TX_MIN(tfx, tfy), tfz) * (1.0f + 2.0f * gamma_n(3.0f));
    tf = TX_MIN(tf, (float4)(tmax));
    return (tn <= tf) & (tf > 0.0f);
}

/* Whether a traversal of the lanes `active` may use the packet's beam: its bounds hold
 * packet_setup's lanes only. */
static inline int packet_beam(const PacketRay* r, pint active)
{
    return r->beam && !any(active & ~r->active);
}

/* box4_entry (accel/bvh.h) for one box and every lane, each with its interval
 * (r->tmin, tmax): the entry distance, INFINITY for a miss; lanes in m that are parallel to
 * an axis and missed are re-tested exactly. */
inline pfloat box_entry_packet(const PacketRay* r, float lox, float hix, float loy, float hiy, float loz, float hiz,
                               pfloat tmax, pint m)
{
    /* each slab's near and far plane per lane: hi for a negative direction, else lo (for the
     * whole packet at once where its traced lanes share their signs: r->signs; the other
     * lanes' answers are masked off by every caller) */
    pfloat nx_, fx_, ny_, fy_, nz_, fz_;
    int o = r->signs;
    if (TX_PACKET_OCTANT && !r->mixed) {
        nx_ = (pfloat)(o & 1 ? hix : lox); fx_ = (pfloat)(o & 1 ? lox : hix);
        ny_ = (pfloat)(o & 2 ? hiy : loy); fy_ = (pfloat)(o & 2 ? loy : hiy);
        nz_ = (pfloat)(o & 4 ? hiz : loz); fz_ = (pfloat)(o & 4 ? loz : hiz);
    } else {
        nx_ = PSEL_F(r->nx, (pfloat)(hix), (pfloat)(lox)); fx_ = PSEL_F(r->nx, (pfloat)(lox), (pfloat)(hix));
        ny_ = PSEL_F(r->ny, (pfloat)(hiy), (pfloat)(loy)); fy_ = PSEL_F(r->ny, (pfloat)(loy), (pfloat)(hiy));
        nz_ = PSEL_F(r->nz, (pfloat)(hiz), (pfloat)(loz)); fz_ = PSEL_F(r->nz, (pfloat)(loz), (pfloat)(hiz));
    }
    pfloat tnx = (nx_ - r->ox) * r->ivx, tfx = (fx_ - r->ox) * r->ivx;
    pfloat tny = (ny_ - r->oy) * r->ivy, tfy = (fy_ - r->oy) * r->ivy;
    pfloat tnz = (nz_ - r->oz) * r->ivz, tfz = (fz_ - r->oz) * r->ivz;
    pfloat tn = PMAX(PMAX(tnx, tny), PMAX(tnz, r->tmin));
    pfloat tf = PMIN(PMIN(tfx, tfy), tfz) * (1.0f + 2.0f * gamma_n(3.0f));
    tf = PMIN(tf, tmax);
    pfloat t = PSEL_F((tn <= tf) & (tf > 0.0f), tn, (pfloat)(INFINITY));
    pint redo = m & r->par & (t == INFINITY);
    if (any(redo)) {                             /* rare: a direction component is zero */
        float tl[TX_PACKET], tl_max[TX_PACKET];
        int rl[TX_PACKET];
        PSTORE(t, tl);
        PSTORE(redo, rl);
        PSTORE(tmax, tl_max);
        for (int j = 0; j < TX_PACKET; ++j)
            if (rl[j])
                tl[j] = box_entry_parallel((float4)(lox, loy, loz, 0.0f), (float4)(hix, hiy, hiz, 0.0f),
                                           (float3)(r->org[0][j], r->org[1][j], r->org[2][j]),
                                           (float3)(r->dir[0][j], r->dir[1][j], r->dir[2][j]), r->range[0][j], tl_max[j]);
        t = PLOAD(tl);
    }
    return t;
}

/* triangle_intersect4's test of the triangle tv against the lanes m of the packet: the
 * lanes with a hit with t in (tmin, tmax), or at t == tmax where `tie` (-1), others 0; their
 * t and barycentrics b1, b2 into *t, *b1, *b2 (the other lanes' are any numbers). */
inline pint triangle_packet(const PacketRay* r, __global const TriVerts* tv, pint m, pfloat tmax, pint tie,
                            pfloat* t, pfloat* b1, pfloat* b2)
{
    float3 a = tri_p0(tv), b = tri_p1(tv), c = tri_p2(tv);
    pfloat ax, ay, bx, by, cx, cy, Akz, Bkz, Ckz;
    pfloat Ax, Ay, Az, Bx, By, Bz, Cx, Cy, Cz;
    if (r->uniform) {
        /* One shear for the whole packet: the vertices' coordinates along its axes, then
         * woop_setup's rows written out, x' = q[kx] - sx q[kz], y' = q[ky] - sy q[kz],
         * z' = sz q[kz] -- the rows' products by their 0 and 1 entries left out. The same
         * floats as the general rows below (adding +-0 to a sum changes at most the sign of
         * a zero, which no test below tells apart), in a third of the arithmetic. */
        int kx = r->kx, ky = r->ky, kz = r->kz;
        pfloat Akx = TX_PAXIS(kx, a.x, a.y, a.z) - r->okx, Aky = TX_PAXIS(ky, a.x, a.y, a.z) - r->oky;
        pfloat Bkx = TX_PAXIS(kx, b.x, b.y, b.z) - r->okx, Bky = TX_PAXIS(ky, b.x, b.y, b.z) - r->oky;
        pfloat Ckx = TX_PAXIS(kx, c.x, c.y, c.z) - r->okx, Cky = TX_PAXIS(ky, c.x, c.y, c.z) - r->oky;
        Akz = TX_PAXIS(kz, a.x, a.y, a.z) - r->okz;
        Bkz = TX_PAXIS(kz, b.x, b.y, b.z) - r->okz;
        Ckz = TX_PAXIS(kz, c.x, c.y, c.z) - r->okz;
        ax = Akx - r->sx * Akz; ay = Aky - r->sy * Akz;
        bx = Bkx - r->sx * Bkz; by = Bky - r->sy * Bkz;
        cx = Ckx - r->sx * Ckz; cy = Cky - r->sy * Ckz;
    } else {
        Ax = a.x - r->ox; Ay = a.y - r->oy; Az = a.z - r->oz;
        Bx = b.x - r->ox; By = b.y - r->oy; Bz = b.z - r->oz;
        Cx = c.x - r->ox; Cy = c.y - r->oy; Cz = c.z - r->oz;
        ax = TX_WOOP_SHEAR(r->rxx, r->rxy, r->rxz, Ax, Ay, Az); ay = TX_WOOP_SHEAR(r->ryx, r->ryy, r->ryz, Ax, Ay, Az);
        bx = TX_WOOP_SHEAR(r->rxx, r->rxy, r->rxz, Bx, By, Bz); by = TX_WOOP_SHEAR(r->ryx, r->ryy, r->ryz, Bx, By, Bz);
        cx = TX_WOOP_SHEAR(r->rxx, r->rxy, r->rxz, Cx, Cy, Cz); cy = TX_WOOP_SHEAR(r->ryx, r->ryy, r->ryz, Cx, Cy, Cz);
    }
    pfloat U, V, W;
    TX_WOOP_EDGES(U, V, W, ax, ay, bx, by, cx, cy);
#ifdef cl_khr_fp64
    if (any(m & ((U == 0.0f) | (V == 0.0f) | (W == 0.0f))))
        TX_PACKET_EXACT_EDGES(U, V, W, ax, ay, bx, by, cx, cy);
#endif
    pint ok = m & (((U >= 0.0f) & (V >= 0.0f) & (W >= 0.0f)) | ((U <= 0.0f) & (V <= 0.0f) & (W <= 0.0f)));
    if (!any(ok)) return ok;
    pfloat det = U + V + W;
    pfloat az, bz, cz;
    if (r->uniform) {
        az = r->sz * Akz; bz = r->sz * Bkz; cz = r->sz * Ckz;
    } else {
        az = TX_WOOP_SHEAR(r->rzx, r->rzy, r->rzz, Ax, Ay, Az); bz = TX_WOOP_SHEAR(r->rzx, r->rzy, r->rzz, Bx, By, Bz);
        cz = TX_WOOP_SHEAR(r->rzx, r->rzy, r->rzz, Cx, Cy, Cz);
    }
    pfloat T = U * az + V * bz + W * cz;
    pfloat inv = 1.0f / det;
    pfloat tt = T * inv;
    ok &= (det != 0.0f) & (tt > r->tmin) & ((tt < tmax) | ((tt == tmax) & tie));
    if (!any(ok)) return ok;
    pfloat delta_t;
    TX_WOOP_DELTA_T(pfloat, delta_t, ax, ay, az, bx, by, bz, cx, cy, cz, U, V, W, inv);
    *t = tt;
    *b1 = V * inv;
    *b2 = W * inv;
    return ok & (tt > delta_t);
}

/* The lanes of m whose ray hits the triangle tv in its (tmin, tmax). */
static inline pint triangle_any_packet(const PacketRay* r, __global const TriVerts* tv, pint m)
{
    pfloat t, b1, b2;
    return triangle_packet(r, tv, m, r->tmax, (pint)(0), &t, &b1, &b2);
}

/* Whether leaves of `kind` have a packet test (prim_packet). */
static inline int prim_packet_kind(uint kind)
{
    int k = 0;                 /* #if, not TX_QUADS && ...: clang warns of || with a constant operand */
#if TX_QUADS
    k |= kind == PRIM_QUAD;
#endif
#if TX_SPHERES
    k |= kind == PRIM_SPHERE;
#endif
    return k;
}

/* Primitive i of a leaf of `kind` (prim_packet_kind) against the lanes m, each with its
 * (tmin, tmax): the lanes with a hit, their t into *t and, for a quad, the patch's (u, v)
 * into *u, *v (a sphere leaves them). */
static inline pint prim_packet(TX_GEOM_PARAMS, const PacketRay* r, uint kind, uint i, pint m, pfloat tmax,
                               pfloat* t, pfloat* u, pfloat* v)
{
#if TX_QUADS
    if (kind == PRIM_QUAD) {
        __global const QuadVerts* qv = quads + i;
        return quad_intersect_packet(r, quad_p0(qv), quad_p1(qv), quad_p2(qv), quad_p3(qv), m, tmax, t, u, v);
    }
#endif
#if TX_SPHERES
    if (kind == PRIM_SPHERE)
        return sphere_intersect_packet(r, spheres + i, m, tmax, t);
#endif
    return (pint)(0);
}

/* The leaf (first, ck) against the lanes m: the lanes with a hit. Triangles, quads and spheres
 * one at a time against the packet; every other kind lane by lane through leaf_hit. */
inline pint leaf_any_packet(TX_GEOM_PARAMS, PacketRay* r, uint first, uint ck, pint m)
{
    uint end = first + (ck & LEAF_COUNT_MASK), kind = ck >> LEAF_COUNT_BITS;
    pint hit = (pint)(0);
    if (TX_TRIANGLES && kind == PRIM_TRIANGLE) {
        packet_shear_once(r);
        uint count = end > first ? end - first : 0u;     /* as leaf_hit: no index wraps */
        for (uint k = 0; k < count; ++k) {
            hit |= triangle_any_packet(r, tris + first + k, m & ~hit);
            if (!any(m & ~hit)) break;
        }
        return hit;
    }
    if (prim_packet_kind(kind)) {
        for (uint i = first; i < end; ++i) {
            pfloat t, u, v;
            hit |= prim_packet(TX_GEOM_ARGS, r, kind, i, m & ~hit, r->tmax, &t, &u, &v);
            if (!any(m & ~hit)) break;
        }
        return hit;
    }
#if TX_SCALAR_KINDS                              /* geometry/dispatch.h */
    int ml[TX_PACKET], hl[TX_PACKET];
    PSTORE(m, ml);
    for (int j = 0; j < TX_PACKET; ++j) {
        hl[j] = 0;
        if (!ml[j]) continue;
        float3 o = (float3)(r->org[0][j], r->org[1][j], r->org[2][j]);
        float3 d = (float3)(r->dir[0][j], r->dir[1][j], r->dir[2][j]);
        WoopRay w = leaf_ray(o, d);
        HitRec h = { r->range[1][j], 0.0f, 0.0f, TX_MISS };
        hl[j] = leaf_hit(TX_GEOM_ARGS, &w, o, d, r->range[0][j], first, ck, 1, 1, &h) ? -1 : 0;
    }
    return (pint)(TX_LANES(hl));
#else
    return hit;                                  /* no other kind in the program: nothing hit */
#endif
}

/* One child lane s_ (s0..s3) of the wide node in bvh_any_packet: the lanes of m that enter
 * its box test its leaf at once or push it with their mask, as bvh_any does per ray. */
#define TX_PACKET_CHILD(s_) do { if (bh.s_) { \
    pint e_ = m & ~occ & (box_entry_packet(r, lox.s_, hix.s_, loy.s_, hiy.s_, loz.s_, hiz.s_, r->tmax, m & ~occ) \
                          < INFINITY); \
    if (any(e_)) { \
        if (kk.s_ != 0u) { \
            occ |= leaf_any_packet(TX_GEOM_ARGS, r, ch.s_, kk.s_, e_); \
            if (!any(active & ~occ)) return occ; \
        } else if (sp < TX_STACK_SIZE) {         /* full: dropped, as in bvh_any */ \
            stack[sp] = ch.s_; stack_m[sp] = e_; ++sp; \
        } \
    } \
} } while (0)

/* bvh_any (accel/bvh.h) for the lanes `active` of the packet: -1 where something is hit
 * in the lane's (tmin, tmax). The callers check every active ray with ray_valid first, as
 * bvh_any does. The same bounds as bvh_any: at most TX_STACK_SIZE entries (a push that
 * finds the stack full is dropped), at most nnodes wide nodes entered, each with an index
 * below nnodes (in a corrupt tree the lanes not yet hit answer 0). */
inline pint bvh_any_packet(TX_GEOM_PARAMS, PacketRay* r, pint active)
{
    pint occ = (pint)(0);
    if (nnodes == 0u || !any(active)) return occ;
    uint stack[TX_STACK_SIZE];
    pint stack_m[TX_STACK_SIZE];
    int sp = 0;
    uint node = 0u, budget = nnodes;
    pint m = active;
    int beam = packet_beam(r, active);
    for (;;) {
        if (node >= nnodes || budget-- == 0u) return occ;
        __global const float4* nd = nodes + 8u * node;
        float4 lox = nd[0], hix = nd[1], loy = nd[2], hiy = nd[3], loz = nd[4], hiz = nd[5];
        uint4 ch = as_uint4(nd[6]), kk = as_uint4(nd[7]);
        int4 bh = beam ? beam_box4(r, lox, hix, loy, hiy, loz, hiz, r->bmax.w) : (int4)(-1);
        TX_PACKET_CHILD(s0);
        TX_PACKET_CHILD(s1);
        TX_PACKET_CHILD(s2);
        TX_PACKET_CHILD(s3);
        for (;;) {                               /* pop an entry with a lane still in flight */
            if (sp == 0) return occ;
            --sp;
            m = stack_m[sp] & ~occ;
            if (any(m)) break;
        }
        node = stack[sp];
    }
}
#undef TX_PACKET_CHILD


/* The closest hits of a packet's lanes, as HitRec holds them: t (tmax for none), the
 * barycentrics (or a patch's uv) and prim (TX_MISS for none). */
typedef struct {
    pfloat t, b1, b2;
    pint prim;
} PacketHit;

/* triangle_intersect4's choice for the triangle tv (the scene's triangle `index`) and the
 * lanes m: a lane takes the hit where t is in (tmin, h.t), or t == h.t and index is below
 * the hit's prim -- the same tie rule (header comment). */
static inline void triangle_closest_packet(const PacketRay* r, __global const TriVerts* tv, uint index, pint m,
                                           PacketHit* h)
{
    pint tie = (h->prim != (pint)(-1)) & (as_puint((pint)(index)) < as_puint(h->prim));
    pfloat t, b1, b2;
    pint ok = triangle_packet(r, tv, m, h->t, tie, &t, &b1, &b2);
    if (!any(ok)) return;
    h->t = PSEL_F(ok, t, h->t);
    h->b1 = PSEL_F(ok, b1, h->b1);
    h->b2 = PSEL_F(ok, b2, h->b2);
    h->prim = PSEL_I(ok, (pint)(index), h->prim);
}

/* The leaf (first, ck) against the lanes m, nearer hits updating h: triangles, quads and
 * spheres one at a time against the packet; every other kind lane by lane through leaf_hit. */
inline void leaf_closest_packet(TX_GEOM_PARAMS, PacketRay* r, uint first, uint ck, pint m, PacketHit* h)
{
    uint end = first + (ck & LEAF_COUNT_MASK), kind = ck >> LEAF_COUNT_BITS;
    if (TX_TRIANGLES && kind == PRIM_TRIANGLE) {
        packet_shear_once(r);
        uint count = end > first ? end - first : 0u;     /* as leaf_hit: no index wraps */
        for (uint k = 0; k < count; ++k)
            triangle_closest_packet(r, tris + first + k, first + k, m, h);
        return;
    }
    if (prim_packet_kind(kind)) {
        for (uint i = first; i < end; ++i) {
            pfloat t, u = h->b1, v = h->b2;          /* a sphere keeps them, as leaf_hit does */
            pint ok = prim_packet(TX_GEOM_ARGS, r, kind, i, m, h->t, &t, &u, &v);
            h->t = PSEL_F(ok, t, h->t);
            h->b1 = PSEL_F(ok, u, h->b1);
            h->b2 = PSEL_F(ok, v, h->b2);
            h->prim = PSEL_I(ok, (pint)((int)((kind << HIT_KIND_SHIFT) | i)), h->prim);
        }
        return;
    }
#if TX_SCALAR_KINDS                              /* geometry/dispatch.h */
    float ht[TX_PACKET], hb1[TX_PACKET], hb2[TX_PACKET];
    int hp[TX_PACKET], ml[TX_PACKET];
    PSTORE(h->t, ht); PSTORE(h->b1, hb1); PSTORE(h->b2, hb2); PSTORE(h->prim, hp); PSTORE(m, ml);
    for (int j = 0; j < TX_PACKET; ++j) {
        if (!ml[j]) continue;
        float3 o = (float3)(r->org[0][j], r->org[1][j], r->org[2][j]);
        float3 d = (float3)(r->dir[0][j], r->dir[1][j], r->dir[2][j]);
        WoopRay w = leaf_ray(o, d);
        HitRec hr = { ht[j], hb1[j], hb2[j], (uint)hp[j] };
        leaf_hit(TX_GEOM_ARGS, &w, o, d, r->range[0][j], first, ck, 0, 1, &hr);
        ht[j] = hr.t; hb1[j] = hr.b1; hb2[j] = hr.b2; hp[j] = (int)hr.prim;
    }
    h->t = (pfloat)(TX_LANES(ht)); h->b1 = (pfloat)(TX_LANES(hb1)); h->b2 = (pfloat)(TX_LANES(hb2));
    h->prim = (pint)(TX_LANES(hp));
#endif
}

/* Compare-exchange of two children (packet entry, child, count_kind, lane mask, entries). */
#define TX_PSORT2(i, j) do { if (n[j] < n[i]) { float nt_ = n[i]; n[i] = n[j]; n[j] = nt_; \
    uint u_ = c[i]; c[i] = c[j]; c[j] = u_; u_ = k[i]; k[i] = k[j]; k[j] = u_; \
    pint m_ = em[i]; em[i] = em[j]; em[j] = m_; pfloat e_ = et[i]; et[i] = et[j]; et[j] = e_; } } while (0)

/* bvh_closest (accel/bvh.h) for the lanes `active` of the packet (rays the caller checked
 * with ray_valid; inactive lanes answer t = tmax, prim = TX_MISS, as an invalid ray does).
 * A node's four boxes are tested against every lane in flight; the children a lane enters
 * are visited nearest first by the packet's nearest entry, the others pushed with the lanes
 * that entered them and their entry distances, and a popped entry keeps only the lanes whose
 * entry is still within their closest hit. Every lane ends with the scalar traversal's hit
 * (see triangle_closest_packet). The same bounds as bvh_closest: at most TX_STACK_SIZE
 * entries (a push that finds the stack full is dropped), at most nnodes wide nodes entered,
 * each with an index below nnodes. */
inline PacketHit bvh_closest_packet(TX_GEOM_PARAMS, PacketRay* r, pint active)
{
    PacketHit h;
    h.t = r->tmax; h.b1 = (pfloat)(0.0f); h.b2 = (pfloat)(0.0f); h.prim = (pint)(-1);
    if (nnodes == 0u || !any(active)) return h;
    uint stack[TX_STACK_SIZE], stack_ck[TX_STACK_SIZE];
    pint stack_m[TX_STACK_SIZE];
    pfloat stack_t[TX_STACK_SIZE];
    int sp = 0;
    uint node = 0u, ck = 0u, budget = nnodes;
    pint m = active;
    int beam = packet_beam(r, active);
    for (;;) {
        if (ck != 0u) {
            leaf_closest_packet(TX_GEOM_ARGS, r, node, ck, m, &h);
        } else {
            if (node >= nnodes || budget-- == 0u) return h;     /* only in a broken tree */
            __global const float4* nd = nodes + 8u * node;
            float4 lox = nd[0], hix = nd[1], loy = nd[2], hiy = nd[3], loz = nd[4], hiz = nd[5];
            uint4 ch = as_uint4(nd[6]), kk = as_uint4(nd[7]);
            pfloat et[4];
            pint em[4];
            float n[4];
            uint c[4] = { ch.x, ch.y, ch.z, ch.w }, k[4] = { kk.x, kk.y, kk.z, kk.w };
            /* the beam's far bound: the farthest current hit of the lanes in flight */
            int4 bh = beam ? beam_box4(r, lox, hix, loy, hiy, loz, hiz, packet_max(PSEL_F(m, h.t, (pfloat)(-INFINITY))))
                           : (int4)(-1);
            pfloat miss = (pfloat)(INFINITY);
            et[0] = bh.s0 ? box_entry_packet(r, lox.s0, hix.s0, loy.s0, hiy.s0, loz.s0, hiz.s0, h.t, m) : miss;
            et[1] = bh.s1 ? box_entry_packet(r, lox.s1, hix.s1, loy.s1, hiy.s1, loz.s1, hiz.s1, h.t, m) : miss;
            et[2] = bh.s2 ? box_entry_packet(r, lox.s2, hix.s2, loy.s2, hiy.s2, loz.s2, hiz.s2, h.t, m) : miss;
            et[3] = bh.s3 ? box_entry_packet(r, lox.s3, hix.s3, loy.s3, hiy.s3, loz.s3, hiz.s3, h.t, m) : miss;
            for (int i = 0; i < 4; ++i) {
                em[i] = m & (et[i] < INFINITY);
                n[i] = packet_min(PSEL_F(em[i], et[i], (pfloat)(INFINITY)));
            }
            TX_PSORT2(0, 1); TX_PSORT2(2, 3); TX_PSORT2(0, 2); TX_PSORT2(1, 3); TX_PSORT2(1, 2);
            if (n[0] < INFINITY) {
                for (int i = 3; i > 0; --i) {
                    if (n[i] < INFINITY && sp < TX_STACK_SIZE) {   /* full: dropped, as in bvh_closest */
                        stack[sp] = c[i]; stack_ck[sp] = k[i]; stack_m[sp] = em[i]; stack_t[sp] = et[i]; ++sp;
                    }
                }
                node = c[0]; ck = k[0]; m = em[0];
                continue;
            }
        }
        for (;;) {                      /* pop an entry with a lane that can still find a closer hit */
            if (sp == 0) return h;
            --sp;
            m = stack_m[sp] & (stack_t[sp] <= h.t);
            if (any(m)) break;
        }
        node = stack[sp]; ck = stack_ck[sp];
    }
}
#undef TX_PSORT2

#endif
