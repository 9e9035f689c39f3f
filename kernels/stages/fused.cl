#line 2 "stages/fused.cl"
/* All five stages in one kernel: each work-item takes one pixel of the tile (or a few
 * neighbouring ones: `pixels` below) through `nsamples` samples (raygen -> closest hit ->
 * surface -> shadow rays -> shading) and adds their sum to the pixel's accumulator (its first
 * launch, sample0 0, writes it), and writes the pixel's mean so far to the image. Same functions,
 * same samples, same image as the staged pipeline, without the per-ray
 * records between stages in global memory; the stage kernels stay for timing
 * each stage alone and for the AOV pass. */

/* With TX_ADAPTIVE (adaptive sampling, texray.renderer.adaptive) the work-items take the
 * tile's pixels listed in `active` (n of them; work-item gid the entries gid * pixels ..;
 * NULL in the first round: pixels 0 .. n - 1)
 * and each also adds the squares of its samples' luminance to sum_y2, for the variance
 * estimate; otherwise work-item gid takes pixels gid * pixels .. of the tile and both are
 * NULL. A later round's launches read the list's length where the decision before left it
 * (listed_n, not n): the host does not wait for it (render_fused below).
 *
 * With TX_ONE_LIGHT (render(light_sampling="one")) each sample traces one shadow ray, toward
 * the light light_pick (core/sampler.h) gives it, and weighs that light by the light count;
 * otherwise every sample sums every light. */
#if TX_PACKET
#define TX_CHUNK TX_PACKET
#else
#define TX_CHUNK 1
#endif
/* `pixels` (1 to TX_CHUNK): with TX_MULTI_PIXEL, the pixels each work-item takes, pixels
 * gid * pixels .. + pixels - 1 of the tile (with TX_ADAPTIVE those of its entries of the
 * list), so that a launch whose samples per pixel are no multiple of the packet's lanes
 * leaves fewer of them empty (texray.device.features.pixels_per_item; a kernel argument, so
 * that every such spp shares one program): the chunks run over the pixels' samples in
 * order, pixel by pixel. Without it one pixel per work-item, the argument unused: the
 * per-pixel arrays are then single values the compiler keeps in registers (a runtime count
 * of 1 measured 14% slower on the globe at 16 spp). */
#if TX_MULTI_PIXEL
#define TX_PIX_MAX TX_CHUNK
#else
#define TX_PIX_MAX 1
#endif
/* Light blocks (one light per sample, packets of several pixels' samples; not with adaptive
 * sampling, whose light order differs per pixel): where the lights take the pixels' samples in
 * blocks of b >= 2 (core/sampler.h light_block; then every pixel's sample k takes the same
 * light, light_offset) and a chunk holds TX_CHUNK / b pixels (texray.device.features.
 * pixels_per_item), chunk c holds block c of each of its pixels, lane j pixel j / b: all its
 * lanes take one light and its shadow rays are one coherent packet, where a chunk of one
 * pixel's consecutive samples took both lights of two (16 lanes, blocks of 8: one packet toward
 * both lights, which traversed about as much as two coherent ones; README, Light sampling).
 * Each pixel's samples are still summed in order (block by block), so the image is the same.
 * TX_LIGHT_BLOCKS: texray.device.features.light_blocks. */
#if TX_LIGHT_BLOCKS && !(TX_ONE_LIGHT && !TX_ADAPTIVE && TX_MULTI_PIXEL && TX_PACKET && !TX_INSTANCES)
#error "TX_LIGHT_BLOCKS: one light per sample in packets of several pixels only (texray.device.features.light_blocks)"
#endif

/* The kernel's body, a function of its own (TX_KERNEL_BODY, core/common.h): on PoCL one
 * call per work-item, out of line. PoCL compiles a kernel three times over (the kernel and
 * its two work-group launchers, each with the kernel inlined); as a call the body is compiled
 * once, which took 0.1 s (12%) off the mixed bench scene's first launch (texray bench's cold
 * build; the body runs for a whole pixel's samples, so the call costs nothing measurable). */
TX_KERNEL_BODY void render_fused_body(uint gid, __global float4* accum, __global float* rgb, __global const uint* active,
                                      __global float* sum_y2, uint n, uint y0, uint sample0, uint nsamples,
                                      uint pixels, uint seed, uint jitter, TX_GEOM_PARAMS, TX_SURFACE_PARAMS,
                                      TX_LIGHT_PARAMS, float4 ambient, float4 background)
{
#if TX_ADAPTIVE
    pixels = clamp(pixels, 1u, (uint)TX_PIX_MAX);
    if (gid >= (n + (pixels - 1u)) / pixels) return;
    uint npix = TX_MIN(n - gid * pixels, pixels);
    uint pixid[TX_PIX_MAX];                       /* the listed pixels' indices in the tile */
    float y2[TX_PIX_MAX];
    for (uint q = 0; q < npix; ++q) {
        pixid[q] = active ? active[gid * pixels + q] : gid * pixels + q;     /* NULL: every pixel */
        y2[q] = 0.0f;
    }
#define TX_PIXEL(q) pixid[q]
#elif TX_PIX_MAX > 1
    pixels = clamp(pixels, 1u, (uint)TX_PIX_MAX);
    if (gid >= (n + (pixels - 1u)) / pixels) return;
    uint first = gid * pixels, npix = TX_MIN(n - first, pixels);
#define TX_PIXEL(q) (first + (q))
#else
    if (gid >= n) return;
    uint first = gid;
    const uint npix = 1u;
#define TX_PIXEL(q) (first + (q))
#endif
    uint grid_m = cmj_grid_m(spp);
    uint ppx[TX_PIX_MAX], ppy[TX_PIX_MAX], pattern[TX_PIX_MAX];
    float3 sum[TX_PIX_MAX];
#if TX_ONE_LIGHT
    uint block = light_block(spp, nlights);
    uint loff[TX_PIX_MAX];                           /* the pixels' light offsets (core/sampler.h) */
#endif
    for (uint q = 0; q < npix; ++q) {
        uint pix = TX_PIXEL(q);
        ppx[q] = pix % image_w; ppy[q] = y0 + pix / image_w;
        pattern[q] = pixel_pattern(image_w, ppx[q], ppy[q], seed);
        sum[q] = (float3)(0.0f);
#if TX_ONE_LIGHT
        loff[q] = light_offset(pattern[q], spp, nlights);
#endif
    }
    /* The npix pixels' samples in chunks of TX_CHUNK, pixel by pixel (with light blocks block
     * by block, each chunk one block of every pixel: above): the chunk's camera
     * rays, hits and surfaces, then each light's shadow rays for the whole chunk, then the
     * samples' sums. With TX_PACKET the camera rays and each light's shadow rays are one
     * packet traversal each (accel/packet.h); else TX_CHUNK is 1 and this is the plain
     * per-sample loop. Every pixel adds the same terms in the same order either way. */
    uint total = npix * nsamples;
#if TX_PACKET && !TX_INSTANCES && TX_PIX_MAX > 1
#if TX_LIGHT_BLOCKS
    /* seg: the light blocks' length where a chunk holds block c of each pixel (above), else 0 */
    uint seg = block > 1u && npix * block == (uint)TX_CHUNK && nsamples % block == 0u && sample0 % block == 0u
               ? block : 0u;
#else
    const uint seg = 0u;
#endif
    /* the lanes' pixels and samples as vectors (below) with light blocks or where a chunk
     * holds whole pixels; log2 of seg (light_block's b is a power of two) and of nsamples
     * (core/sampler.h cmj_log2: no llvm.ctlz or ctpop, which Oclgrind cannot run) */
    uint lseg = seg ? cmj_log2(seg) : 0u, lns = cmj_log2(TX_MAX(nsamples, 1u));
    int lanes_vec = seg || (nsamples <= (uint)TX_CHUNK && (1u << lns) == nsamples);
#endif
#if TX_PACKET && !TX_INSTANCES
    /* the samples' positions in their pixels, computed for two chunks of 8 at a time (core/sampler.h
     * TX_CMJ_W) */
    float jxw[TX_CMJ_W], jyw[TX_CMJ_W];
#endif
    for (uint k0 = 0; k0 < total; k0 += TX_CHUNK) {
        uint m = TX_MIN(total - k0, (uint)TX_CHUNK);
        Surface s[TX_CHUNK];
        float3 v[TX_CHUNK], c[TX_CHUNK];
#if !TX_PACKET
        float3 sorg[TX_CHUNK];
        int lifted[TX_CHUNK];
#endif
        uchar vis[TX_CHUNK];
        uint lp[TX_CHUNK];                           /* each sample's pixel (0 .. npix - 1) */
        /* the light lane j's sample picked (core/sampler.h light_pick): its sample in the pixel,
         * lr[j] where the lanes' samples were stepped (several pixels' packets) */
#if TX_PACKET && !TX_INSTANCES && TX_PIX_MAX > 1
#define TX_LIGHT_PICK(j) light_pick(sample0 + lr[j], pattern[lp[j]], loff[lp[j]], nlights, block)
#else
#define TX_LIGHT_PICK(j) light_pick(sample0 + k0 + (j) - lp[j] * nsamples, pattern[lp[j]], loff[lp[j]], nlights, block)
#endif
#if TX_PACKET && !TX_INSTANCES
        /* the chunk's camera rays, then their closest hits as one packet (accel/packet.h) */
        PacketRay pr;
        int act[TX_CHUNK];
        uint jo = k0 % (uint)TX_CMJ_W;               /* the chunk's lanes in jxw, jyw */
        pfloat fpx, fpy;                             /* their pixels' coordinates */
#if TX_PIX_MAX > 1
        /* Each lane's pixel (lp) and sample in it (lr); lanes past the end repeat the last
         * sample, never traced. As vectors (TX_LANES_QR: lane g = k0 + j of the work-item's
         * sequence) where the launch's samples per pixel are a power of two up to TX_CHUNK
         * (whole pixels in a chunk: every several-pixel launch at 1, 2, 4 or 8 spp) -- pixel
         * g / nsamples, sample g % nsamples -- or with light blocks (seg) -- pixel
         * (g % TX_CHUNK) / seg, sample (g / TX_CHUNK) seg + g % seg --, each pixel's coordinates
         * and pattern selected into its lanes (TX_LANES_SEL, one select per pixel of the
         * chunk); else stepped lane by lane (no division per lane). The scalar stepping was
         * 7% of the brick wall's instructions at 4 spp (callgrind). */
        uint lr[TX_CHUNK];
        uint q0 = npix == 1u ? 0u : k0 / nsamples, r0 = k0 - q0 * nsamples;
#define TX_LANES_QR(T_, g_, q_, r_) do {                                                          \
            if (seg) {                                                                            \
                q_ = ((g_) & (T_)((uint)TX_CHUNK - 1u)) >> lseg;                                  \
                r_ = (((g_) / (T_)((uint)TX_CHUNK)) << lseg) + ((g_) & (T_)(seg - 1u));           \
            } else {                                                                              \
                T_ gc_ = PSEL_I(as_##T_((g_) > (T_)(total - 1u)), (T_)(total - 1u), g_);          \
                q_ = gc_ >> lns; r_ = gc_ & (T_)(nsamples - 1u);                                  \
            }                                                                                     \
        } while (0)
#define TX_LANES_SEL(T_, q_, lo_, hi_, tab_, out_) do {                                           \
            out_ = (T_)(tab_[lo_]);                                                               \
            for (uint p_ = (lo_) + 1u; p_ <= (hi_); ++p_)                                         \
                out_ = PSEL_I(as_##T_((q_) == (T_)(p_)), (T_)(tab_[p_]), out_);                   \
        } while (0)
/* the pixels lanes k0 .. k0 + w_ - 1 take: every pixel with light blocks, else from k0's */
#define TX_LANES_LO (seg ? 0u : k0 >> lns)
#define TX_LANES_HI(w_) (seg ? npix - 1u : TX_MIN(k0 + (w_) - 1u, total - 1u) >> lns)
        if (lanes_vec) {
            puint qv, rv, vx, vy;
            TX_LANES_QR(puint, (puint)(k0) + TX_PKT_LANE_IDS, qv, rv);
            TX_LANES_SEL(puint, qv, TX_LANES_LO, TX_LANES_HI((uint)TX_CHUNK), ppx, vx);
            TX_LANES_SEL(puint, qv, TX_LANES_LO, TX_LANES_HI((uint)TX_CHUNK), ppy, vy);
            PSTORE(qv, lp); PSTORE(rv, lr);
            fpx = TX_PKT_TO_FLOAT(vx); fpy = TX_PKT_TO_FLOAT(vy);
        } else {
            uint lpx[TX_CHUNK], lpy[TX_CHUNK];
            for (uint j = 0, q = q0, r = r0; j < (uint)TX_CHUNK; ++j) {
                lp[j] = q; lr[j] = r;
                lpx[j] = ppx[q]; lpy[j] = ppy[q];
                if (k0 + j + 1u < total && ++r == nsamples) { r = 0u; ++q; }
            }
            fpx = TX_PKT_TO_FLOAT(TX_PKT_ULOAD(lpx)); fpy = TX_PKT_TO_FLOAT(TX_PKT_ULOAD(lpy));
        }
        if (jitter && jo == 0u) {                    /* the positions of samples k0 .. k0 + TX_CMJ_W - 1 */
            uint16 lsv, lpatv;
            if (lanes_vec) {
                uint16 q16, r16;
                TX_LANES_QR(uint16, (uint16)(k0) + (uint16)TX_LANE_IDS_16, q16, r16);
                lsv = (uint16)(sample0) + r16;
                TX_LANES_SEL(uint16, q16, TX_LANES_LO, TX_LANES_HI((uint)TX_CMJ_W), pattern, lpatv);
            } else {
                uint ls[TX_CMJ_W], lpat[TX_CMJ_W];
                for (uint j = 0, q = q0, r = r0; j < (uint)TX_CMJ_W; ++j) {
                    ls[j] = sample0 + r;
                    lpat[j] = pattern[q];
                    if (k0 + j + 1u < total && ++r == nsamples) { r = 0u; ++q; }
                }
                lsv = vload16(0, ls); lpatv = vload16(0, lpat);
            }
#undef TX_LANES_QR
#undef TX_LANES_SEL
#undef TX_LANES_LO
#undef TX_LANES_HI
#if TX_PACKET == 8
            if (total - k0 <= 8u)                    /* one chunk left: 8 lanes (core/sampler.h) */
                cmj_sample_packet8(lsv.lo, spp, grid_m, lpatv.lo, jxw, jyw);
            else
#endif
                cmj_sample_packet16(lsv, spp, grid_m, lpatv, jxw, jyw);
        }
#else
        for (uint j = 0; j < (uint)TX_CHUNK; ++j)
            lp[j] = 0u;
        fpx = (pfloat)((float)ppx[0]); fpy = (pfloat)((float)ppy[0]);
        if (jitter && jo == 0u) {   /* one pixel: its samples k0 .. k0 + TX_CMJ_W - 1 of one pattern (lanes past
                                     * the end repeat the last, never traced; 8 lanes where one chunk is left) */
            uint first_s = sample0 + k0, last = sample0 + total - 1u;
#if TX_PACKET == 8
            if (total - k0 <= 8u) {
                uint8 sv = (uint8)(first_s) + (uint8)TX_LANE_IDS_8, past = as_uint8(sv > (uint8)(last));
                cmj_sample_packet8((sv & ~past) | ((uint8)(last) & past), spp, grid_m, (uint8)(pattern[0]), jxw, jyw);
            } else
#endif
            {
                uint16 sv = (uint16)(first_s) + (uint16)TX_LANE_IDS_16, past = as_uint16(sv > (uint16)(last));
                cmj_sample_packet16((sv & ~past) | ((uint16)(last) & past), spp, grid_m, (uint16)(pattern[0]),
                                    jxw, jyw);
            }
        }
#endif
        /* the camera rays as one vector computation (core/camera_packet.h); lanes past the
         * chunk's end or with an invalid ray are not traced (origin 0, direction +z) */
        {
            pfloat pjx = (pfloat)(0.5f), pjy = (pfloat)(0.5f);
            if (jitter) { pjx = PLOAD(jxw + jo); pjy = PLOAD(jyw + jo); }
            pfloat3 d = camera_dir_packet(cam, image_w, image_h, fpx, fpy, pjx, pjy);
            float3 eye = vload3(0, cam->eye);
            pint live = ray_valid_packet(eye, d) & (as_pint(TX_PKT_LANE_IDS) < (pint)((int)m));
            PSTORE(PSEL_F(live, (pfloat)(eye.x), (pfloat)(0.0f)), pr.org[0]);
            PSTORE(PSEL_F(live, (pfloat)(eye.y), (pfloat)(0.0f)), pr.org[1]);
            PSTORE(PSEL_F(live, (pfloat)(eye.z), (pfloat)(0.0f)), pr.org[2]);
            PSTORE(PSEL_F(live, d.x, (pfloat)(0.0f)), pr.dir[0]);
            PSTORE(PSEL_F(live, d.y, (pfloat)(0.0f)), pr.dir[1]);
            PSTORE(PSEL_F(live, d.z, (pfloat)(1.0f)), pr.dir[2]);
            PSTORE((pfloat)(0.0f), pr.range[0]);
            PSTORE((pfloat)(INFINITY), pr.range[1]);
            PSTORE(live, act);
        }
        pint traced = PLOAD(act);                    /* the lanes traced */
        packet_setup(&pr, traced);
        PacketHit ph = bvh_closest_packet(TX_GEOM_ARGS, &pr, traced);
        float ht[TX_CHUNK], hb1[TX_CHUNK], hb2[TX_CHUNK];
        int hp[TX_CHUNK];
        PSTORE(ph.t, ht); PSTORE(ph.b1, hb1); PSTORE(ph.b2, hb2); PSTORE(ph.prim, hp);
#if TX_SPHERES || TX_QUADS || TX_TRI_GEOM_PACKET
        /* the sphere, quad and triangle hits' geometry as one vector computation per kind
         * (geometry/sphere_packet.h, quad_packet.h, triangle_packet.h: the scalar geometry's
         * bits) */
        Geom pre[TX_CHUNK];
        uint pidx[TX_CHUNK];
        int has_pre[TX_CHUNK];
        PSTORE(as_puint(ph.prim) & (puint)(HIT_INDEX_MASK), pidx);
        pint hit_kind = as_pint(as_puint(ph.prim) >> HIT_KIND_SHIFT), pre_lanes = (pint)(0);
#if TX_SURFACE_PACKET
        /* the geometry as vectors for surface_packet, not as records (shading/surface_packet.h) */
        GeomLanes glanes;
        glanes.set = 0;
#define TX_GEOM_AOS ((Geom*)0)
#define TX_GEOM_SOA (&glanes)
#else
#define TX_GEOM_AOS pre
#define TX_GEOM_SOA ((GeomLanes*)0)
#endif
#if TX_SPHERES
        pint on_sphere = traced & (hit_kind == (int)PRIM_SPHERE);
        if (any(on_sphere))
            sphere_geom_packet(spheres, pidx, on_sphere, pf3(pr.ox, pr.oy, pr.oz), pf3(pr.dx, pr.dy, pr.dz), ph.t, TX_GEOM_AOS, TX_GEOM_SOA);
        pre_lanes |= on_sphere;
#endif
#if TX_QUADS
        pint on_quad = traced & (hit_kind == (int)PRIM_QUAD);
        if (any(on_quad))
            quad_geom_packet(quads, quad_shade, pidx, on_quad, ph.b1, ph.b2, TX_GEOM_AOS, TX_GEOM_SOA);
        pre_lanes |= on_quad;
#endif
#if TX_TRI_GEOM_PACKET
        pint on_tri = traced & (hit_kind == (int)PRIM_TRIANGLE);
        if (any(on_tri))
            triangle_geom_packet(tris, tri_shade, uvs, pidx, on_tri, ph.b1, ph.b2, TX_GEOM_AOS, TX_GEOM_SOA);
        pre_lanes |= on_tri;
#endif
        PSTORE(pre_lanes, has_pre);
#if TX_SURFACE_PACKET
        /* their surfaces as one vector computation too (shading/surface_packet.h); the loop
         * below evaluates the other lanes */
        SurfLanes sv;
        if (any(pre_lanes)) {
            int hkl[TX_CHUNK];
            PSTORE(hit_kind, hkl);
            surface_packet(&pr, has_pre, hkl, pidx, hb1, hb2, &glanes, TX_GEOM_ARGS, TX_SURFACE_ARGS, &sv);
#if !TX_SURF_LANES
            surface_records(&sv, has_pre, s, v);     /* read back as records below */
#endif
        } else {                                     /* no surfaces: every lane a miss */
            pfloat3 z = pf3_splat((float3)(0.0f));
            sv.p = z; sv.ng = z; sv.ns = z; sv.kd = z; sv.ks = z; sv.wo = z; sv.lift = z;
            sv.offset = (pfloat)(0.0f); sv.shin = (pfloat)(0.0f); sv.valid = (pint)(0);
        }
#endif
#undef TX_GEOM_AOS
#undef TX_GEOM_SOA
#define TX_PRE_GEOM(j) (has_pre[j] ? pre + (j) : (const Geom*)0)
#else
#define TX_PRE_GEOM(j) ((const Geom*)0)
#endif
        for (uint j = 0; j < m; ++j) {
#if TX_SURFACE_PACKET
            if (has_pre[j]) continue;                /* surface_packet's */
            /* Where every hit is the packet's, the other lanes missed: the scalar surface_eval
             * below is then dead code, left out of the kernel (its code generation was a
             * quarter of such a program's first launch). */
            if (TX_SURFACE_PACKET_ONLY) { s[j].valid = 0u; continue; }
#endif
            /* the traced ray; a lane not traced has none to shade (its hit: a miss) */
            float3 org = (float3)(pr.org[0][j], pr.org[1][j], pr.org[2][j]);
            float3 dir = (float3)(pr.dir[0][j], pr.dir[1][j], pr.dir[2][j]);
            HitRec h = { ht[j], hb1[j], hb2[j], (uint)hp[j] };
#else
        for (uint j = 0; j < m; ++j) {
            uint kk = k0 + j;
            lp[j] = npix == 1u ? 0u : kk / nsamples;
            uint q = lp[j];
            float2 jit = jitter ? cmj_sample_m(sample0 + kk - q * nsamples, spp, grid_m, pattern[q])
                                : (float2)(0.5f, 0.5f);
            float3 org, dir;
            camera_ray(cam, image_w, image_h, ppx[q], ppy[q], jit, &org, &dir);
            HitRec h = bvh_closest(TX_GEOM_ARGS, org, dir, 0.0f, INFINITY);
#define TX_PRE_GEOM(j) ((const Geom*)0)
#endif
            surface_eval(org, dir, h, TX_PRE_GEOM(j), TX_GEOM_ARGS, TX_SURFACE_ARGS, (__global float*)0,
                         TX_PIXEL(lp[j]), s + j);
#undef TX_PRE_GEOM
            if (s[j].valid) v[j] = -normalize3(dir);
        }
#if TX_SURF_LANES
        /* Every hit is the packet's (shading/surface_packet.h TX_SURF_LANES): the chunk's
         * colours, shadow origins and light terms computed from its surfaces as vectors,
         * without records: the same operations per lane as the records' path below */
        pfloat3 cv = pf3_sel(sv.valid, pf3(ambient.x * sv.kd.x, ambient.y * sv.kd.y, ambient.z * sv.kd.z),
                             pf3_splat(background.xyz));
        /* a chunk without surfaces (every ray a miss: the sky) has no shadow rays or light
         * terms: its lights are skipped, not traced with every lane masked off */
        int lit = nlights && any(sv.valid);
        ShadowLanes sl;
        if (lit)
            shadow_origins_lanes(sv.p, sv.lift, sv.ng, sv.ns, sv.offset, sv.valid, &sl);
        /* cv += light_term where the light at lp_ (intensity li_) is visible (the lane mask vm_
         * of light_visible_lanes: lanes from m on are 0, and no sum below reads them) */
#define TX_ADD_LIGHT(vm_, lp_, li_) do { \
            if (any(vm_)) \
                cv = pf3_sel(vm_, pf3_add(cv, light_term_lanes(sv.p, sv.ns, sv.kd, sv.ks, sv.shin, sv.wo, lp_, li_, \
                                                               vm_)), cv); \
        } while (0)
#if TX_ONE_LIGHT
        if (lit) {
            float3 lposj[TX_CHUNK], lij[TX_CHUNK];
            for (uint j = 0; j < m; ++j) {
                uint pick = TX_LIGHT_PICK(j);
                lposj[j] = vload3(0, lights[pick].position);
                lij[j] = light_intensity(vload3(0, lights[pick].intensity), nlights);
            }
            pfloat3 lpv = pf3_gather(lposj, 1u, m), liv = pf3_gather(lij, 1u, m);
            pint vm = light_visible_lanes(&sl, m, &lpv, TX_GEOM_ARGS);
            TX_ADD_LIGHT(vm, lpv, liv);
        }
#else
        if (lit) FOR_EACH_LIGHT(i, nlights) {
            pfloat3 lpv = pf3_splat(vload3(0, lights[i].position));
            pint vm = light_visible_lanes(&sl, m, &lpv, TX_GEOM_ARGS);
            TX_ADD_LIGHT(vm, lpv, pf3_splat(light_intensity(vload3(0, lights[i].intensity), nlights)));
        }
#endif
#undef TX_ADD_LIGHT
        /* the colours clamped as vectors (clamp_radiance lane by lane), read by the sums below */
        float cl[3][TX_CHUNK];
        PSTORE(pf_clamp_radiance(cv.x), cl[0]); PSTORE(pf_clamp_radiance(cv.y), cl[1]);
        PSTORE(pf_clamp_radiance(cv.z), cl[2]);
#define TX_SAMPLE_C(j) ((float3)(cl[0][j], cl[1][j], cl[2][j]))
#else
        /* What reads the records back, in a loop of its own: read right after surface_eval
         * wrote them (as scalars), their vector fields' loads waited on the stores (perf put
         * the globe's hottest instruction there); apart, tools/ab.py measured 0.98 of the
         * frame time on the globe and the brick wall. */
        for (uint j = 0; j < m; ++j) {
            c[j] = background.xyz;
            if (s[j].valid) {
                c[j] = ambient.xyz * vload3(0, s[j].kd);
#if !TX_PACKET
                sorg[j] = shadow_origin(s + j, lifted + j);
#endif
            }
        }
#if TX_PACKET
        /* as above: a chunk without surfaces has no shadow rays or light terms */
        int lit = 0;
        for (uint j = 0; j < m; ++j) lit |= s[j].valid != 0u;
        lit = lit && nlights;
        /* the shadow origins as vectors, once for every light (shading/shadow.h) */
        ShadowLanes sl;
        if (lit)
            shadow_origins_packet(s, m, &sl);
#else
        /* one sample: light_visible skips a miss's shadow rays itself (a test of lit here
         * changed how Intel's runtime vectorizes the loop, and its rounding in the last bit) */
        const int lit = nlights != 0u;
#endif
        /* the shadow rays: with TX_ONE_LIGHT each sample's toward the light it picked
         * (core/sampler.h light_pick), as one packet for the chunk; otherwise each light's
         * for the whole chunk */
#if TX_ONE_LIGHT
        float3 lposj[TX_CHUNK];
        uint pick[TX_CHUNK];
        if (lit) {
            for (uint j = 0; j < m; ++j) {
                pick[j] = TX_LIGHT_PICK(j);
                lposj[j] = vload3(0, lights[pick[j]].position);
            }
#if TX_PACKET
            pfloat3 lpv = pf3_gather(lposj, 1u, m);
            light_visible_packet(&sl, m, &lpv, TX_GEOM_ARGS, vis);
#else
            for (uint j = 0; j < m; ++j)
                vis[j] = s[j].valid && light_visible(s + j, sorg[j], lifted[j], lposj[j], TX_GEOM_ARGS);
#endif
#if TX_LIGHT_PACKET
            float3 lij[TX_CHUNK];
            for (uint j = 0; j < m; ++j)
                lij[j] = light_intensity(vload3(0, lights[pick[j]].intensity), nlights);
            light_term_packet(s, v, lposj, lij, 1u, vis, m, c);
#else
            for (uint j = 0; j < m; ++j)
                if (vis[j])
                    c[j] += light_term(s + j, v[j], lposj[j], light_intensity(vload3(0, lights[pick[j]].intensity),
                                                                              nlights));
#endif
        }
#else
        if (lit) FOR_EACH_LIGHT(i, nlights) {
            float3 lpos = vload3(0, lights[i].position);
#if TX_PACKET
            float3 lposj[TX_CHUNK];
            for (uint j = 0; j < (uint)TX_CHUNK; ++j) lposj[j] = lpos;
            pfloat3 lpv = pf3_splat(lpos);
            light_visible_packet(&sl, m, &lpv, TX_GEOM_ARGS, vis);
#else
            for (uint j = 0; j < m; ++j)
                vis[j] = s[j].valid && light_visible(s + j, sorg[j], lifted[j], lpos, TX_GEOM_ARGS);
#endif
            float3 li = light_intensity(vload3(0, lights[i].intensity), nlights);
#if TX_LIGHT_PACKET
            light_term_packet(s, v, lposj, &li, 0u, vis, m, c);
#else
            for (uint j = 0; j < m; ++j)
                if (vis[j]) c[j] += light_term(s + j, v[j], lpos, li);
#endif
        }
#endif
#endif
        /* the samples' sums, in sample order; with one pixel per work-item its index as the
         * constant it is, so that the sum stays in a register (indexed by lp[j], a load,
         * each addition waited on the store before it: 1.2% of the globe's frame, perf) */
#if TX_PIX_MAX > 1
#define TX_LP(j) lp[j]
#else
#define TX_LP(j) 0u
#endif
#ifndef TX_SAMPLE_C
#define TX_SAMPLE_C(j) clamp_radiance(c[j])
#endif
        for (uint j = 0; j < m; ++j) {
            float3 cj = TX_SAMPLE_C(j);
            sum[TX_LP(j)] += cj;
#if TX_ADAPTIVE
            float y = luminance(cj);                                       /* core/adaptive.h */
            y2[TX_LP(j)] += y * y;
#endif
        }
#undef TX_LP
#undef TX_SAMPLE_C
#undef TX_LIGHT_PICK
    }
    /* The pixels' first samples (sample0 0) start the sums, later launches add to them: 0 +
     * the sum, as the sums of a buffer zeroed first (the host filled it until 2026-12-07: a
     * command and a pass over the tile's memory per frame, 0.1-0.6 ms of a 512x256 frame). */
    for (uint q = 0; q < npix; ++q) {
        float4 a = (sample0 ? accum[TX_PIXEL(q)] : (float4)(0.0f)) + (float4)(sum[q], (float)nsamples);
        accum[TX_PIXEL(q)] = a;
        pixel_mean(a, TX_PIXEL(q), rgb);
    }
#if TX_ADAPTIVE
    for (uint q = 0; q < npix; ++q)
        sum_y2[TX_PIXEL(q)] = (sample0 ? sum_y2[TX_PIXEL(q)] : 0.0f) + y2[q];
#endif
#undef TX_PIXEL
}

/* With adaptive sampling's later rounds (listed_n not NULL: the length of the list `active`,
 * which the decision before wrote on the device) the host launches a fixed number of
 * work-items without waiting for that length, and each takes groups of `pixels` list entries
 * (TX_FOR_LISTED, stages/adaptive.cl): every group as one work-item of a launch sized to the
 * list would (the same samples, in the same packets), and no round trip to the host between
 * rounds (0.35 ms from the list's end to the next round's start on the brick wall's 14 ms
 * adaptive frame; a launch of a work-item per group of the whole tile, most of them idle, cost
 * 0.23 ms on its own). */
__kernel void render_fused(__global float4* accum, __global float* rgb, __global const uint* active,
                           __global const uint* listed_n, __global float* sum_y2, uint n,
                           uint y0, uint sample0, uint nsamples, uint pixels, uint seed, uint jitter,
                           TX_GEOM_PARAMS, TX_SURFACE_PARAMS, TX_LIGHT_PARAMS, float4 ambient, float4 background)
{
#if TX_ADAPTIVE
    if (listed_n) {
        uint m = *listed_n, p = clamp(pixels, 1u, (uint)TX_PIX_MAX);
        TX_FOR_LISTED(g, (m + (p - 1u)) / p)
            render_fused_body(g, accum, rgb, active, sum_y2, m, y0, sample0, nsamples, pixels, seed, jitter,
                              TX_GEOM_ARGS, TX_SURFACE_ARGS, TX_LIGHT_ARGS, ambient, background);
        return;
    }
#endif
    render_fused_body(TX_GID(), accum, rgb, active, sum_y2, n, y0, sample0, nsamples, pixels, seed, jitter,
                      TX_GEOM_ARGS, TX_SURFACE_ARGS, TX_LIGHT_ARGS, ambient, background);
}
