#line 2 "core/slab.h"
/* The slab test of one axis (Kay and Kajiya 1986): the interval of t where a ray's
 * coordinate o + t d lies in [lo, hi], intersected into [*tn, *tf]. Boxes are three
 * such axes: accel/bvh.h's exact test for rays with a zero direction component, and
 * geometry/displace.h's bounding volumes (a quad's slab in its local coordinates, a
 * cylinder shell's z range). The BVH's four-box test (box4_entry) keeps its own
 * float4 form, with the reciprocal direction: it is the traversal's inner loop. */
#ifndef TEXRAY_SLAB_H
#define TEXRAY_SLAB_H
#include "core/accurate.h"

/* Clips [*tn, *tf] to the t with lo <= o + t d <= hi; returns 0 where the axis excludes
 * every t (and then leaves the interval as it is). The distances (lo - o) / d and
 * (hi - o) / d are divided, not multiplied by a reciprocal, so d = 0 needs no care in
 * them; d = 0 is tested first instead: such an axis bounds nothing while o lies in
 * [lo, hi] (boundaries included) and excludes everything otherwise (NaN o too). The
 * far distance is multiplied by far_scale: 1 + 2 gamma(3) makes the test conservative
 * under float rounding (Ize 2013, "Robust BVH Ray Traversal"), 1 leaves it exact (the
 * caller widened the slab instead). Whether the interval is empty is the caller's test
 * (*tn <= *tf), after all axes. */
static inline int slab_clip(float o, float d, float lo, float hi, float far_scale, float* tn, float* tf)
{
    if (d == 0.0f) return o >= lo && o <= hi;
    float t0 = (lo - o) / d, t1 = (hi - o) / d;
    *tn = TX_MAX(*tn, TX_MIN(t0, t1));
    *tf = TX_MIN(*tf, TX_MAX(t0, t1) * far_scale);
    return 1;
}

#endif
