#line 2 "shading/surface_packet.h"
/* Surface evaluation for a packet's hits at once, a lane each: what surface_eval
 * (shading/surface.h) computes for a hit whose geometry the packet already has
 * (stages/fused.cl's sphere, quad and triangle packets), written as vectors over the
 * lanes -- the bilinear lookups' coordinates, wrap modes and weights, bump mapping's
 * gradient and normal, the normals turned to the viewer, the material terms and the
 * record's checks -- where the scalar code did them lane after lane (a third of a
 * bumped brick wall's frame, perf). Only the texel reads stay one lane at a time.
 *
 * Every lane computes surface_eval's arithmetic in the same order with the same
 * contraction (off here, as after core/accurate.h; dot and cross as core/common.h
 * compiles them: accel/packet_vec.h), so the record is surface_eval's bit for bit
 * (tests/render/test_surface_packet.py: images with packets against those without).
 *
 * Compiled in (TX_SURFACE_PACKET) for the programs whose surfaces need nothing else:
 * packets, bilinear textures alone, no projections, labels, specular, shininess or normal
 * maps, AOVs or instances, and some sphere, quad or triangle packet
 * geometry. A hit without the packet's geometry (a cylinder, a displaced shape) is still
 * evaluated lane by lane. Not on Intel's CPU compiler, where packets are the user's choice
 * (TEXRAY_PACKET) and which rounds vector divisions and square roots apart from scalar ones
 * (geometry/triangle_packet.h): its surfaces stay surface_eval's. */
#ifndef TEXRAY_SURFACE_PACKET_H
#define TEXRAY_SURFACE_PACKET_H
#include "shading/surface.h"
#include "accel/packet.h"

#if TX_PACKET && !TX_INSTANCES && !TX_AOVS && !TX_PROJECTIONS && !TX_LABELS \
    && !TX_SPECULAR_MAPS && !TX_SHININESS_MAPS && !TX_NORMAL_MAPS && !TX_FILTER_NEAREST && !TX_FILTER_TRILINEAR \
    && !TX_FILTER_ANISOTROPIC && (TX_SPHERES || TX_QUADS || TX_TRI_GEOM_PACKET) && !defined(__INTEL_LLVM_COMPILER)
#define TX_SURFACE_PACKET 1
#else
#define TX_SURFACE_PACKET 0
#endif
/* Whether every kind of hit the program can meet has the packet's geometry (no cylinders,
 * displaced shapes or instances), so that the fused kernel needs no scalar surface_eval. */
#if TX_SURFACE_PACKET && !TX_CYLINDERS && !TX_DISPLACEMENT && (!TX_TRIANGLES || TX_TRI_GEOM_PACKET)
#define TX_SURFACE_PACKET_ONLY 1
#else
#define TX_SURFACE_PACKET_ONLY 0
#endif
/* Where every hit is the packet's and the light terms are packets too (PoCL), the fused
 * kernel shades the chunk from surface_packet's vectors (SurfLanes) and writes no records
 * (stages/fused.cl); elsewhere surface_records writes them for the records' path. */
#define TX_SURF_LANES (TX_SURFACE_PACKET_ONLY && TX_LIGHT_PACKET)

#if TX_SURFACE_PACKET
#pragma OPENCL FP_CONTRACT OFF

#if TX_PACKET == 16
#define convert_pint convert_int16
#define convert_pfloat convert_float16
#else
#define convert_pint convert_int8
#define convert_pfloat convert_float8
#endif

/* The lanes' textures: TextureInfo fields, one lane each (texture_level 0: bilinear). */
typedef struct {
    pint off, w, h, mode;
    pfloat m0x, m0y, m0z, m0w, m1x, m1y;
} TexPacket;

/* The lanes' TextureInfo fields, one read per lane: out of line, as packets whose lanes use
 * several textures are few (an object's edge). ti_: each lane's texture. */
static __attribute__((noinline)) void tex_gather_packet(__global const TextureInfo* textures, const int* ti_,
                                                        TexPacket* t)
{
    int a[4][TX_PACKET];
    float b[6][TX_PACKET];
    for (uint j = 0; j < (uint)TX_PACKET; ++j) {
        __global const TextureInfo* ti = textures + ti_[j];
        a[0][j] = (int)ti->offset; a[1][j] = (int)ti->width; a[2][j] = (int)ti->height; a[3][j] = (int)ti->wrap;
        for (int k = 0; k < 4; ++k) b[k][j] = ti->m0[k];
        b[4][j] = ti->m1[0]; b[5][j] = ti->m1[1];
    }
    t->off = PLOAD(a[0]); t->w = PLOAD(a[1]); t->h = PLOAD(a[2]); t->mode = PLOAD(a[3]);
    t->m0x = PLOAD(b[0]); t->m0y = PLOAD(b[1]); t->m0z = PLOAD(b[2]); t->m0w = PLOAD(b[3]);
    t->m1x = PLOAD(b[4]); t->m1y = PLOAD(b[5]);
}

/* The textures tex[j] of the lanes `ml` (others read the first such lane's) into *t: one read
 * where they all use one texture (a wall, a floor: nearly every packet). (An out-parameter,
 * not a returned TexPacket: inlined, a struct's return slot left llvm.experimental.noalias.
 * scope.decl calls that Oclgrind 21.10 cannot run, as shading/surface.h says.) */
static inline __attribute__((always_inline)) void tex_packet(__global const TextureInfo* textures, const int* tex,
                                                             const int* ml, TexPacket* t)
{
    uint k0 = packet_first_lane(ml);
    if (packet_one_index(ml, (const uint*)tex, k0)) {
        __global const TextureInfo* ti = textures + tex[k0];
        t->off = (pint)((int)ti->offset); t->w = (pint)((int)ti->width); t->h = (pint)((int)ti->height);
        t->mode = (pint)((int)ti->wrap);
        t->m0x = (pfloat)(ti->m0[0]); t->m0y = (pfloat)(ti->m0[1]); t->m0z = (pfloat)(ti->m0[2]);
        t->m0w = (pfloat)(ti->m0[3]); t->m1x = (pfloat)(ti->m1[0]); t->m1y = (pfloat)(ti->m1[1]);
        return;
    }
    int ti_[TX_PACKET];
    for (uint j = 0; j < (uint)TX_PACKET; ++j) ti_[j] = ml[j] ? tex[j] : tex[k0];
    tex_gather_packet(textures, ti_, t);
}

/* texture/mapping.h's uv_transform of (u, v) by each lane's texture, into *su, *sv. */
static inline __attribute__((always_inline)) void uv_transform_packet(const TexPacket* t, pfloat u, pfloat v,
                                                                      pfloat* su, pfloat* sv)
{
    *su = t->m0x * u + t->m0y * v + t->m1x;
    *sv = t->m0z * u + t->m0w * v + t->m1y;
}

/* texture/wrap.h's wrap_reduce, lane by lane. */
static inline __attribute__((always_inline)) pfloat wrap_reduce_packet(pfloat u, pint mode)
{
    pfloat c = PSEL_F(u < -1.0f, (pfloat)(-1.0f), PSEL_F(u > 2.0f, (pfloat)(2.0f), u));
    pfloat r = PSEL_F(mode == TX_WRAP_MIRROR, u - 2.0f * floor(0.5f * u), u - floor(u));
    r = PSEL_F(fabs(u) == INFINITY, (pfloat)(0.0f), r);
    r = PSEL_F(mode == TX_WRAP_CLAMP, c, r);
    return PSEL_F(u != u, (pfloat)(0.0f), r);
}

/* wrap_index for the lanes j of both fl and ml, into rl[j]: out of line, as it is (nearly) never
 * run (a call's code once, not in each of the lookups). */
static __attribute__((noinline)) void wrap_index_lanes(const int* il, const int* nl, const int* mode, const int* fl,
                                                       const int* ml, int* rl)
{
    for (uint j = 0; j < (uint)TX_PACKET; ++j)
        if (fl[j] && ml[j]) rl[j] = wrap_index(il[j], nl[j], mode[j]);
}

/* texture/wrap.h's wrap_index, lane by lane, for the indices a reduced coordinate gives
 * (i in [-n, 2n) for repeat, [-2n, 4n) for mirror: one period's step); the lanes of `ml`
 * beyond them, if any, take the scalar function. */
static inline __attribute__((always_inline)) pint wrap_index_packet(pint i, pint n, pint mode, const int* ml)
{
    pint p = n + n;
    pint c = PSEL_I(i < 0, (pint)(0), PSEL_I(i >= n, n - 1, i));
    pint m = PSEL_I(i < 0, i + p, PSEL_I(i >= p, i - p, i));
    m = PSEL_I(m < n, m, p - 1 - m);
    pint r = PSEL_I(i < 0, i + n, PSEL_I(i >= n, i - n, i));
    r = PSEL_I(mode == TX_WRAP_CLAMP, c, PSEL_I(mode == TX_WRAP_MIRROR, m, r));
    r = PSEL_I(as_pint(as_puint(i) < as_puint(n)), i, r);
    r = PSEL_I(n <= 1, (pint)(0), r);
    pint far = (mode != TX_WRAP_CLAMP) & (n > 1) & (PSEL_I(mode == TX_WRAP_MIRROR, i < -p, i < -n)
                                                   | PSEL_I(mode == TX_WRAP_MIRROR, i >= p + p, i >= p));
    if (any(far)) {                              /* not met by reduced coordinates; kept exact */
        int il[TX_PACKET], nl[TX_PACKET], ml_[TX_PACKET], rl[TX_PACKET], fl[TX_PACKET];
        PSTORE(i, il); PSTORE(n, nl); PSTORE(mode, ml_); PSTORE(r, rl); PSTORE(far, fl);
        wrap_index_lanes(il, nl, ml_, fl, ml, rl);
        r = PLOAD(rl);
    }
    return r;
}

/* The four taps of texture_bilinear_level (level 0) for the lanes `ml` at transformed
 * coordinates (u, v): their texel indices and the weights ax, ay (bilinear_taps). */
static __attribute__((noinline)) void bilinear_taps_packet(const TexPacket* t, const pfloat* up, const pfloat* vp,
                                                            const int* ml, pint* i00, pint* i10, pint* i01,
                                                            pint* i11, pfloat* ax, pfloat* ay)
{
    pfloat u = *up, v = *vp;
    pfloat x = wrap_reduce_packet(u, t->mode) * convert_pfloat(t->w) - 0.5f;
    pfloat y = (1.0f - wrap_reduce_packet(v, t->mode)) * convert_pfloat(t->h) - 0.5f;
    pfloat fx = floor(x), fy = floor(y);
    pint ix = convert_pint(fx), iy = convert_pint(fy);
    pint x0 = wrap_index_packet(ix, t->w, t->mode, ml), x1 = wrap_index_packet(ix + 1, t->w, t->mode, ml);
    pint y0 = wrap_index_packet(iy, t->h, t->mode, ml), y1 = wrap_index_packet(iy + 1, t->h, t->mode, ml);
    /* texel_at: offset + y w + x, in uint */
    puint off = as_puint(t->off), w = as_puint(t->w);
    *i00 = as_pint(off + as_puint(y0) * w + as_puint(x0));
    *i10 = as_pint(off + as_puint(y0) * w + as_puint(x1));
    *i01 = as_pint(off + as_puint(y1) * w + as_puint(x0));
    *i11 = as_pint(off + as_puint(y1) * w + as_puint(x1));
    *ax = x - fx;
    *ay = y - fy;
}

/* texture_bilinear_level's blend of one channel, lane by lane. */
#define TX_BLEND_P(c00, c10, c01, c11, ax, ay) \
    (((c00) * (1.0f - (ax)) + (c10) * (ax)) * (1.0f - (ay)) + ((c01) * (1.0f - (ax)) + (c11) * (ax)) * (ay))

/* Texel channels of the lanes `ml` at indices i (others 0): `nch` channels (1: red only). */
static inline __attribute__((always_inline)) void texels_packet(__global const half* texels, pint i, const int* ml,
                                                                int nch, pfloat* r, pfloat* g, pfloat* b)
{
    int il[TX_PACKET];
    float rl[TX_PACKET], gl[TX_PACKET], bl[TX_PACKET];
    PSTORE(i, il);
    #pragma nounroll
    for (uint j = 0; j < (uint)TX_PACKET; ++j) {
        float4 c = ml[j] ? vload_half4((uint)il[j], texels) : (float4)(0.0f);
        rl[j] = c.x; gl[j] = c.y; bl[j] = c.z;
    }
    *r = PLOAD(rl);
    if (nch > 1) { *g = PLOAD(gl); *b = PLOAD(bl); }
}

#if TX_BUMP
/* texture_bilinear(texels, ti, uv).x of the lanes `ml` (bump_value). */
static __attribute__((noinline)) void bilinear_red_packet(__global const half* texels, const TexPacket* t,
                                                           const pfloat* u, const pfloat* v, const int* ml,
                                                           pfloat* out)
{
    pint i00, i10, i01, i11;
    pfloat ax, ay, r[4], unused;
    bilinear_taps_packet(t, u, v, ml, &i00, &i10, &i01, &i11, &ax, &ay);
    texels_packet(texels, i00, ml, 1, r, &unused, &unused);
    texels_packet(texels, i10, ml, 1, r + 1, &unused, &unused);
    texels_packet(texels, i01, ml, 1, r + 2, &unused, &unused);
    texels_packet(texels, i11, ml, 1, r + 3, &unused, &unused);
    *out = TX_BLEND_P(r[0], r[1], r[2], r[3], ax, ay);
}

/* shading/bump.h's bump_gradient (level 0: no MIP filter in these programs) of the lanes
 * `ml`, at their untransformed uv: (B_u, B_v) into *gu, *gv. */
static inline __attribute__((always_inline)) void bump_gradient_packet(__global const half* texels,
                                                                      const TexPacket* t, pfloat u, pfloat v,
                                                                      pfloat height, pfloat delta, const int* ml,
                                                                      pfloat* gu, pfloat* gv)
{
    pfloat su, sv;
    uv_transform_packet(t, u, v, &su, &sv);
    pfloat gx, gy;
    /* lane by lane: as vectors (any() of the two masks), Oclgrind 21.10 computed the brick
     * wall's bumps wrongly (0.08 off PoCL's and Intel's images at 4 spp) */
    int dl[TX_PACKET], exact = 0, diff = 0;
    PSTORE(as_pint(delta < 0.0f), dl);
    for (uint j = 0; j < (uint)TX_PACKET; ++j) {
        exact |= ml[j] && dl[j];
        diff |= ml[j] && !dl[j];
    }
    pfloat ex = (pfloat)(0.0f), ey = (pfloat)(0.0f), cx = (pfloat)(0.0f), cy = (pfloat)(0.0f);
    if (exact) {                                 /* bump_gradient_bilinear */
        int me[TX_PACKET];
        for (uint j = 0; j < (uint)TX_PACKET; ++j) me[j] = ml[j] && dl[j];
        pint i00, i10, i01, i11;
        pfloat ax, ay, c[4], unused;
        bilinear_taps_packet(t, &su, &sv, me, &i00, &i10, &i01, &i11, &ax, &ay);
        texels_packet(texels, i00, me, 1, c, &unused, &unused);
        texels_packet(texels, i10, me, 1, c + 1, &unused, &unused);
        texels_packet(texels, i01, me, 1, c + 2, &unused, &unused);
        texels_packet(texels, i11, me, 1, c + 3, &unused, &unused);
        /* bilinear_gradient */
        pfloat dx = (c[1] - c[0]) * (1.0f - ay) + (c[3] - c[2]) * ay;
        pfloat dy = (c[2] - c[0]) * (1.0f - ax) + (c[3] - c[1]) * ax;
        ex = dx * convert_pfloat(t->w);
        ey = -dy * convert_pfloat(t->h);
    }
    if (diff) {                                  /* central differences */
        int md[TX_PACKET];
        for (uint j = 0; j < (uint)TX_PACKET; ++j) md[j] = ml[j] && !dl[j];
        pfloat dx = PSEL_F(delta > 0.0f, delta, 1.0f / convert_pfloat(t->w));   /* texture_texel_size */
        pfloat dy = PSEL_F(delta > 0.0f, delta, 1.0f / convert_pfloat(t->h));
        pfloat su_[4] = { su + dx, su - dx, su, su }, sv_[4] = { sv, sv, sv + dy, sv - dy }, b[4];
        for (int k = 0; k < 4; ++k)                /* bump_value at uv +- (dx, 0), uv +- (0, dy) */
            bilinear_red_packet(texels, t, su_ + k, sv_ + k, md, b + k);
        cx = (b[0] - b[1]) / (2.0f * dx);
        cy = (b[2] - b[3]) / (2.0f * dy);
    }
    pint e = delta < 0.0f;
    gx = PSEL_F(e, ex, cx);
    gy = PSEL_F(e, ey, cy);
    *gu = height * (gx * t->m0x + gy * t->m0z);
    *gv = height * (gx * t->m0y + gy * t->m0w);
}

#endif

#if TX_BUMP || TX_VERTEX_NORMALS
/* core/frame.h's any_tangent, lane by lane. */
static inline __attribute__((always_inline)) pfloat3 any_tangent_packet(pfloat3 n)
{
    pint bx = fabs(n.x) > fabs(n.z);
    pfloat3 a = pf3(PSEL_F(bx, -n.y, (pfloat)(0.0f)), PSEL_F(bx, n.x, -n.z), PSEL_F(bx, (pfloat)(0.0f), n.y));
    return pf3_normalize3(a);
}

#if TX_BUMP
/* core/frame.h's bump_normal, lane by lane. */
static inline __attribute__((always_inline)) pfloat3 bump_normal_packet(pfloat3 n, pfloat3 dpdu, pfloat3 dpdv,
                                                                       pfloat gu, pfloat gv)
{
    pfloat3 pu = pf3_sub(dpdu, pf3_scale(pf3_dot(dpdu, n), n)), pv = pf3_sub(dpdv, pf3_scale(pf3_dot(dpdv, n), n));
    pfloat j = pf3_dot(pf3_cross(pu, pv), n);
    pfloat3 q = pf3_sub(pf3_scale(gu, pf3_cross(n, pv)), pf3_scale(gv, pf3_cross(n, pu)));
    pfloat3 r = pf3_add(n, pf3(q.x / j, q.y / j, q.z / j));
    pint keep = ((gu == 0.0f) & (gv == 0.0f)) | !(fabs(j) > 0.0f);
    return pf3_sel(keep, n, pf3_unit_or(r, n));
}
#endif

/* shading/bump.h's bump_turn_toward, lane by lane (bound per lane): *ap turned toward *bp. Out
 * of line: called twice, rarely with work to do. */
static __attribute__((noinline)) void turn_toward_packet(pfloat3* ap, const pfloat3* bp, const pfloat* boundp)
{
    pfloat3 a = *ap, b = *bp;
    pfloat bound = *boundp;
    pfloat c = pf3_dot(a, b);
    pint done = c >= bound;
    if (all(done)) return;
    pfloat3 w = pf3_unit_or(pf3_sub(a, pf3_scale(c, b)), any_tangent_packet(b));
    pfloat3 t = pf3_add(pf3_scale(bound, b), pf3_scale(sqrt(1.0f - bound * bound), w));
    *ap = pf3_sel(done, a, t);
}
#endif

#if TX_VERTEX_NORMALS
/* terminator_lift (shading/terminator.h) lane by lane: the same operations in the same
 * order, dot3 contracted as core/common.h compiles it (pf3_dot), the rest not (this file's
 * FP_CONTRACT OFF, as terminator.h's), so each lane's lift is terminator_lift's bit for bit. */
static inline __attribute__((always_inline)) pfloat3 terminator_lift_packet(pfloat3 p, pfloat3 p0, pfloat3 p1,
                                                                            pfloat3 p2, pfloat3 n0, pfloat3 n1,
                                                                            pfloat3 n2, pfloat b0, pfloat b1, pfloat b2)
{
    pfloat zero = (pfloat)(0.0f);
    pfloat d0 = PMIN(zero, pf3_dot(pf3_sub(p, p0), n0));
    pfloat d1 = PMIN(zero, pf3_dot(pf3_sub(p, p1), n1));
    pfloat d2 = PMIN(zero, pf3_dot(pf3_sub(p, p2), n2));
    pfloat3 s = pf3_add(pf3_add(pf3_scale(b0 * d0, n0), pf3_scale(b1 * d1, n1)), pf3_scale(b2 * d2, n2));
    return pf3(-s.x, -s.y, -s.z);
}
#endif

/* The lanes' material terms, one read per lane (mat: each lane's material): out of line, as
 * packets whose lanes have several materials are few. */
#if TX_BUMP
#define TX_MAT_BUMP_PARAMS , pfloat* bh, pfloat* bd
#define TX_MAT_BUMP_ARGS , &bh, &bd
#else
#define TX_MAT_BUMP_PARAMS
#define TX_MAT_BUMP_ARGS
#endif
static __attribute__((noinline)) void material_gather_packet(__global const Material* materials, const int* mat,
                                                             pfloat3* kd, pfloat3* ks, pfloat* shin, int* dtex,
                                                             int* btex TX_MAT_BUMP_PARAMS)
{
    float c[9][TX_PACKET];
    for (uint j = 0; j < (uint)TX_PACKET; ++j) {
        __global const Material* m = materials + mat[j];
        for (int k = 0; k < 3; ++k) { c[k][j] = m->diffuse[k]; c[3 + k][j] = m->specular[k]; }
        c[6][j] = m->shininess; c[7][j] = m->bump_height; c[8][j] = m->bump_delta;
    }
    *kd = pf3(PLOAD(c[0]), PLOAD(c[1]), PLOAD(c[2]));
    *ks = pf3(PLOAD(c[3]), PLOAD(c[4]), PLOAD(c[5]));
    *shin = PLOAD(c[6]);
#if TX_BUMP
    *bh = PLOAD(c[7]); *bd = PLOAD(c[8]);
#endif
    for (uint j = 0; j < (uint)TX_PACKET; ++j) { dtex[j] = materials[mat[j]].diffuse_tex; btex[j] = materials[mat[j]].bump_tex; }
}

/* A packet's surfaces (surface_packet): surface_eval's record fields, one vector each, and
 * the view vector wo = -normalize3(dir); valid: the lanes with a record (a hit the packet
 * evaluated, every field finite), 0 in every other lane, whose fields are any numbers. */
typedef struct {
    pfloat3 p, ng, ns, kd, ks, wo, lift;
    pfloat offset, shin;
    pint valid;
} SurfLanes;

/* surface_eval of lane j's ray and hit for the lanes j of `lanes` (hits on a sphere, quad or
 * triangle, whose geometry the packet left in gl) into *sv. hk, pidx, hb1, hb2: the lanes'
 * hit kinds, primitive indices and barycentrics. */
static inline __attribute__((always_inline)) void surface_packet(const PacketRay* pr, const int* lanes,
                                                                 const int* hk, const uint* pidx, const float* hb1,
                                                                 const float* hb2, const GeomLanes* gl,
                                                                 TX_GEOM_PARAMS, TX_SURFACE_PARAMS, SurfLanes* sv)
{
    /* the geometry and the material, one lane each */
    int mat[TX_PACKET];
    uint k0 = packet_first_lane(lanes);
    #pragma nounroll
    for (uint j = 0; j < (uint)TX_PACKET; ++j) {
        uint i = pidx[lanes[j] ? j : k0];
        int kind = hk[lanes[j] ? j : k0];
        uint mi = 0u;
#if TX_QUADS
        if (kind == (int)PRIM_QUAD) mi = quad_shade[i].material;
#endif
#if TX_SPHERES
        if (kind == (int)PRIM_SPHERE) mi = spheres[i].material;
#endif
#if TX_TRIANGLES
        if (kind == (int)PRIM_TRIANGLE) mi = tri_shade[i].material;
#endif
        mat[j] = (int)mi;
    }
#define TX_GL(k) PLOAD(gl->f[TX_GL_##k])
    pfloat3 p = pf3(TX_GL(PX), TX_GL(PY), TX_GL(PZ)), ng0 = pf3(TX_GL(NX), TX_GL(NY), TX_GL(NZ));
    pfloat u = TX_GL(U), v = TX_GL(V);
    pfloat3 perr = pf3(TX_GL(EX), TX_GL(EY), TX_GL(EZ));
#if TX_BUMP
    pfloat3 dpdu = pf3(TX_GL(UX), TX_GL(UY), TX_GL(UZ)), dpdv = pf3(TX_GL(VX), TX_GL(VY), TX_GL(VZ));
#endif
#undef TX_GL
    pint vlanes = PLOAD(lanes) != (pint)(0), vmat = PLOAD(mat);
    int one = !any(vlanes & (vmat != (pint)(mat[k0])));
    PSTORE(PSEL_I(vlanes, vmat, (pint)(mat[k0])), mat);
    pfloat3 kd, ks;
    pfloat shin;
    int dtex[TX_PACKET], btex[TX_PACKET];
#if TX_BUMP
    pfloat bh, bd;
#endif
    if (one) {
        __global const Material* m = materials + mat[k0];
        kd = pf3_splat(vload3(0, m->diffuse)); ks = pf3_splat(vload3(0, m->specular)); shin = (pfloat)(m->shininess);
        for (uint j = 0; j < (uint)TX_PACKET; ++j) { dtex[j] = m->diffuse_tex; btex[j] = m->bump_tex; }
#if TX_BUMP
        bh = (pfloat)(m->bump_height); bd = (pfloat)(m->bump_delta);
#endif
    } else {
        material_gather_packet(materials, mat, &kd, &ks, &shin, dtex, btex TX_MAT_BUMP_ARGS);
    }
    pfloat3 dir = pf3(PLOAD(pr->dir[0]), PLOAD(pr->dir[1]), PLOAD(pr->dir[2]));
    /* the shading normal (surface_normals): the outward normal (the vertex normals', where a
     * triangle has them: surface_geometry), bumped */
    pfloat3 n_out = ng0;
#if TX_VERTEX_NORMALS
    pfloat3 lift = pf3_splat((float3)(0.0f));    /* the shadow-ray lift */
    int vn[TX_PACKET], anyn = 0;                 /* lanes on a triangle with vertex normals */
    for (uint j = 0; j < (uint)TX_PACKET; ++j) {
        vn[j] = lanes[j] && hk[j] == (int)PRIM_TRIANGLE && (tri_shade[pidx[j]].flags & TRI_HAS_NORMALS);
        anyn |= vn[j];
    }
    pint use_vn = (pint)(0), lift_vn = (pint)(0);
    if (anyn) {
        uint kn = packet_first_lane(vn);
        pfloat b1 = PLOAD(hb1), b2 = PLOAD(hb2);
        pfloat b0 = 1.0f - b1 - b2;
        /* every such lane on one triangle (a pixel's samples mostly are): its normals read
         * once, as vectors of one value (packet_one_index: the same values, the same bits) */
        int one_tri = packet_one_index(vn, pidx, kn);
        pfloat3 n0, n1, n2;
        if (one_tri) {
            __global const TriShade* ts = tri_shade + pidx[kn];
            n0 = pf3_splat(vload3(ts->v[0], normals)); n1 = pf3_splat(vload3(ts->v[1], normals));
            n2 = pf3_splat(vload3(ts->v[2], normals));
        } else {
            float nl[9][TX_PACKET];              /* the three vertex normals, lane by lane */
            for (uint j = 0; j < (uint)TX_PACKET; ++j) {
                /* the three indices read once, each normal's three floats from them (a loop
                 * over the nine floats, c / 3 and c % 3, read the indices again for each: a
                 * fifth of render_fused_body's time on the textured meshes, perf) */
                __global const TriShade* ts = tri_shade + pidx[vn[j] ? j : kn];
                uint i0 = 3u * ts->v[0], i1 = 3u * ts->v[1], i2 = 3u * ts->v[2];
                nl[0][j] = normals[i0]; nl[1][j] = normals[i0 + 1u]; nl[2][j] = normals[i0 + 2u];
                nl[3][j] = normals[i1]; nl[4][j] = normals[i1 + 1u]; nl[5][j] = normals[i1 + 2u];
                nl[6][j] = normals[i2]; nl[7][j] = normals[i2 + 1u]; nl[8][j] = normals[i2 + 2u];
            }
            n0 = pf3(PLOAD(nl[0]), PLOAD(nl[1]), PLOAD(nl[2]));
            n1 = pf3(PLOAD(nl[3]), PLOAD(nl[4]), PLOAD(nl[5]));
            n2 = pf3(PLOAD(nl[6]), PLOAD(nl[7]), PLOAD(nl[8]));
        }
        pfloat3 raw = pf3_add(pf3_add(pf3_scale(b0, n0), pf3_scale(b1, n1)), pf3_scale(b2, n2));
        use_vn = ((pint)(TX_LANES(vn)) != 0) & (pf3_dot(raw, raw) > 0.0f) & pf3_finite(raw);
        lift_vn = use_vn & (pf3_dot(raw, dir) < 0.0f);        /* seen from the normals' side */
        n_out = pf3_sel(use_vn, pf3_normalize3(raw), n_out);
        if (any(lift_vn)) {
            /* surface_geometry's shadow-ray lift (shading/terminator.h) for the lanes lift_vn:
             * their triangles' corners and the unit vertex normals, as vectors */
            pfloat3 q0, q1, q2;
            if (one_tri) {
                __global const TriVerts* tv = tris + pidx[kn];
                q0 = pf3_splat(tri_p0(tv)); q1 = pf3_splat(tri_p1(tv)); q2 = pf3_splat(tri_p2(tv));
            } else {
                float cl[9][TX_PACKET];
                for (uint j = 0; j < (uint)TX_PACKET; ++j) {
                    __global const TriVerts* tv = tris + pidx[vn[j] ? j : kn];
                    float3 a = tri_p0(tv), b = tri_p1(tv), c = tri_p2(tv);
                    cl[0][j] = a.x; cl[1][j] = a.y; cl[2][j] = a.z;
                    cl[3][j] = b.x; cl[4][j] = b.y; cl[5][j] = b.z;
                    cl[6][j] = c.x; cl[7][j] = c.y; cl[8][j] = c.z;
                }
                q0 = pf3(PLOAD(cl[0]), PLOAD(cl[1]), PLOAD(cl[2]));
                q1 = pf3(PLOAD(cl[3]), PLOAD(cl[4]), PLOAD(cl[5]));
                q2 = pf3(PLOAD(cl[6]), PLOAD(cl[7]), PLOAD(cl[8]));
            }
            pfloat3 l = terminator_lift_packet(p, q0, q1, q2, pf3_normalize3(n0), pf3_normalize3(n1),
                                               pf3_normalize3(n2), b0, b1, b2);
            lift = pf3_sel(lift_vn, l, lift);
        }
    }
#endif
#if TX_BUMP
    {
        /* the lanes with a bump map, as a vector (a scalar loop per lane mask: with the
         * material's and the diffuse texture's below, 5% of the brick wall's instructions at
         * 4 spp, callgrind) */
        int mb[TX_PACKET];
        pint vmb = (PLOAD(lanes) != (pint)(0)) & (PLOAD(btex) >= (pint)(0));
        PSTORE(vmb, mb);                             /* -1 or 0: consumers test nonzero */
        if (any(vmb)) {
            PSTORE(PSEL_I(vmb, PLOAD(btex), (pint)(btex[packet_first_lane(mb)])), btex);
            TexPacket bt;
            tex_packet(textures, btex, mb, &bt);
            pfloat gu, gv;
            bump_gradient_packet(texels, &bt, u, v, bh, bd, mb, &gu, &gv);
            pint has = (pint)(TX_LANES(mb)) != 0;
            n_out = pf3_sel(has, bump_normal_packet(n_out, dpdu, dpdv, gu, gv), n_out);
        }
    }
#endif
    pint back = pf3_dot(ng0, dir) > 0.0f;                    /* face the incoming ray */
    pfloat side = PSEL_F(back, (pfloat)(-1.0f), (pfloat)(1.0f));
    pfloat3 ng = pf3_scale(side, ng0), ns = pf3_scale(side, n_out);
    pfloat3 wo = pf3_normalize3(dir);
    wo = pf3(-wo.x, -wo.y, -wo.z);
#if TX_BUMP || TX_VERTEX_NORMALS
    pfloat bound1 = (pfloat)(TX_NORMAL_MIN_COS), cw = pf3_dot(ng, wo);     /* shading_normal_facing */
    turn_toward_packet(&ns, &ng, &bound1);
    pfloat bound2 = PMIN((pfloat)(TX_NORMAL_MIN_COS), PMAX(cw, (pfloat)(0.0f)));
    turn_toward_packet(&ns, &wo, &bound2);
#endif
    /* the material (surface_material): kd through the diffuse texture, its four taps read lane
     * by lane and blended as vectors (texture_bilinear_level's float4 arithmetic per component,
     * contraction off as there: the same floats) */
    if (TX_TEXTURES) {
        int mt[TX_PACKET];
        pint vmt = (PLOAD(lanes) != (pint)(0)) & (PLOAD(dtex) >= (pint)(0));
        PSTORE(vmt, mt);
        if (any(vmt)) {
            uint kt = packet_first_lane(mt);
            PSTORE(PSEL_I(vmt, PLOAD(dtex), (pint)(dtex[kt])), dtex);
            TexPacket dt;
            tex_packet(textures, dtex, mt, &dt);
            pfloat su, sv_;
            uv_transform_packet(&dt, u, v, &su, &sv_);
            pint i00, i10, i01, i11;
            pfloat ax, ay;
            bilinear_taps_packet(&dt, &su, &sv_, mt, &i00, &i10, &i01, &i11, &ax, &ay);
            int ti[4][TX_PACKET], tl[TX_PACKET];
            PSTORE(i00, ti[0]); PSTORE(i10, ti[1]); PSTORE(i01, ti[2]); PSTORE(i11, ti[3]);
            for (uint j = 0; j < (uint)TX_PACKET; ++j) tl[j] = mt[j] ? (int)j : (int)kt;  /* others: a textured lane's */
            /* each tap's texels, four lanes' RGBA to a float16, transposed into a vector per
             * channel by swizzles (scalar stores read back as vectors stalled on the
             * store-to-load forwarding: a tenth of render_fused_body's time, perf) */
#define TX_TAP(k, j) vload_half4((uint)ti[k][tl[j]], texels)
#define TX_QUAD(k, j) (float16)(TX_TAP(k, j), TX_TAP(k, (j) + 1), TX_TAP(k, (j) + 2), TX_TAP(k, (j) + 3))
            pfloat3 tap[4];
            for (int k = 0; k < 4; ++k) {
#if TX_PACKET == 16
                float16 q0 = TX_QUAD(k, 0), q1 = TX_QUAD(k, 4), q2 = TX_QUAD(k, 8), q3 = TX_QUAD(k, 12);
                tap[k] = pf3((pfloat)(q0.s048c, q1.s048c, q2.s048c, q3.s048c),
                             (pfloat)(q0.s159d, q1.s159d, q2.s159d, q3.s159d),
                             (pfloat)(q0.s26ae, q1.s26ae, q2.s26ae, q3.s26ae));
#else
                float16 q0 = TX_QUAD(k, 0), q1 = TX_QUAD(k, 4);
                tap[k] = pf3((pfloat)(q0.s048c, q1.s048c), (pfloat)(q0.s159d, q1.s159d), (pfloat)(q0.s26ae, q1.s26ae));
#endif
            }
#undef TX_QUAD
#undef TX_TAP
            pfloat bx = 1.0f - ax, by = 1.0f - ay;
#define TX_BLEND(c) ((tap[0].c * bx + tap[1].c * ax) * by + (tap[2].c * bx + tap[3].c * ax) * ay)
            pfloat3 blend = pf3(TX_BLEND(x), TX_BLEND(y), TX_BLEND(z));
#undef TX_BLEND
            kd = pf3_sel((pint)(TX_LANES(mt)) != 0, pf3(kd.x * blend.x, kd.y * blend.y, kd.z * blend.z), kd);
        }
    }
    /* the record (surface_write) */
    sv->valid = ((pint)(TX_LANES(lanes)) != 0) & pf3_finite(p) & pf3_finite(ng) & pf3_finite(ns) & pf3_finite(ks)
              & pf3_finite(kd);
    sv->offset = pf3_dot(pf3_abs(ng), perr);                   /* dot3(abs3(ng), perr) */
    sv->p = p; sv->ng = ng; sv->ns = ns; sv->kd = kd; sv->ks = ks; sv->shin = shin; sv->wo = wo;
#if TX_VERTEX_NORMALS
    sv->lift = lift;
#else
    sv->lift = pf3_splat((float3)(0.0f));
#endif
}

/* surface_packet's surfaces as the records s[j] and vout[j] = wo of the lanes j of `lanes`
 * (valid 0 where the lane's surface is not valid; the other lanes' records untouched). */
inline void surface_records(const SurfLanes* sv, const int* lanes, Surface* s, float3* vout)
{
    float o[23][TX_PACKET];
    int vl[TX_PACKET];
    PSTORE(sv->valid, vl);
    PSTORE(sv->p.x, o[0]); PSTORE(sv->p.y, o[1]); PSTORE(sv->p.z, o[2]); PSTORE(sv->offset, o[3]);
    PSTORE(sv->ng.x, o[4]); PSTORE(sv->ng.y, o[5]); PSTORE(sv->ng.z, o[6]);
    PSTORE(sv->ns.x, o[7]); PSTORE(sv->ns.y, o[8]); PSTORE(sv->ns.z, o[9]); PSTORE(sv->shin, o[10]);
    PSTORE(sv->kd.x, o[11]); PSTORE(sv->kd.y, o[12]); PSTORE(sv->kd.z, o[13]);
    PSTORE(sv->ks.x, o[14]); PSTORE(sv->ks.y, o[15]); PSTORE(sv->ks.z, o[16]);
    PSTORE(sv->wo.x, o[17]); PSTORE(sv->wo.y, o[18]); PSTORE(sv->wo.z, o[19]);
    PSTORE(sv->lift.x, o[20]); PSTORE(sv->lift.y, o[21]); PSTORE(sv->lift.z, o[22]);
    #pragma nounroll
    for (uint j = 0; j < (uint)TX_PACKET; ++j) {
        if (!lanes[j]) continue;
        Surface* r = s + j;
        if (!vl[j]) { r->valid = 0u; continue; }
        vstore3((float3)(o[0][j], o[1][j], o[2][j]), 0, r->p);
        r->offset = o[3][j];
        vstore3((float3)(o[4][j], o[5][j], o[6][j]), 0, r->ng);
        r->valid = 1u;
        vstore3((float3)(o[7][j], o[8][j], o[9][j]), 0, r->ns);
        vstore3((float3)(o[20][j], o[21][j], o[22][j]), 0, r->lift);
        r->shininess = o[10][j];
        vstore3((float3)(o[11][j], o[12][j], o[13][j]), 0, r->kd);
        vstore3((float3)(o[14][j], o[15][j], o[16][j]), 0, r->ks);
        vout[j] = (float3)(o[17][j], o[18][j], o[19][j]);
    }
}

#endif
#endif
