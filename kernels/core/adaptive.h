#line 2 "core/adaptive.h"
/* Adaptive sampling's stopping rule (texray.renderer.adaptive says why it is this rule;
 * stages/adaptive.cl runs it between rounds): a pixel's error is the standard error of its
 * mean luminance,
 *
 *     se = sqrt(var / n),   var = (sum Y^2 - sum Y * mean) / (n - 1),   mean = sum Y / n,
 *
 * from the sums the fused kernel adds (accum: sum RGB and the count n; sum_y2), and it
 * has converged when se <= threshold * max(mean, floor). Compared squared, without the
 * square root: var / n > (threshold * max(mean, floor))^2 (both sides >= 0). float32 with
 * the subtraction as one fma (one rounding: var never loses more than that to
 * cancellation; a constant pixel's var is then a few ulps of its sum Y^2, not minus a
 * product's rounding); max(var, 0) for a constant pixel's rounding below zero. A NaN sum
 * compares false: such a pixel stops (clamp_radiance keeps samples finite). Included after
 * core/accurate.h: no contraction but the fma written here. */
#ifndef TEXRAY_ADAPTIVE_H
#define TEXRAY_ADAPTIVE_H
#include "core/common.h"

/* Rec. 709 luminance, what the fused kernel sums the squares of (texray.renderer.adaptive
 * LUMINANCE, the tests' reference). */
static inline float luminance(float3 c) { return 0.2126f * c.x + 0.7152f * c.y + 0.0722f * c.z; }

/* Whether a pixel with these sums has not converged (keeps sampling, with its 3x3
 * neighbours: stages/adaptive.cl). */
static inline int adaptive_open(float4 acc, float sum_y2, float threshold, float floor_y)
{
    float n = acc.w;
    float sum_y = luminance(acc.xyz);
    float mean = sum_y / n;
    float var = TX_MAX(fma(-sum_y, mean, sum_y2), 0.0f) / TX_MAX(n - 1.0f, 1.0f);
    float bound = threshold * TX_MAX(mean, floor_y);
    return var / n > bound * bound;
}

/* for (g = ...) over the groups 0 .. count - 1 of a list whose length only the device knows
 * (adaptive sampling's later rounds: stages/fused.cl render_fused, stages/adaptive.cl
 * adaptive_mark), launched as a fixed number of work-items: work-group w's item l takes
 * groups l W + w, + the global size, ... (W work-groups), so that any count is shared by
 * every work-group -- PoCL hands work-groups to its threads in contiguous runs, and groups in
 * launch order left the last work-groups idle (a round took twice as long). A launch laid out
 * in rows (TX_GID, core/common.h) counts its work-groups row by row: W is every row's. */
#define TX_FOR_LISTED(g, count) \
    for (uint g##_w_ = (uint)(get_global_size(0) / get_local_size(0)), \
         g = (uint)get_local_id(0) * g##_w_ * TX_GRID_ROWS() + TX_GROUP_ROW() * g##_w_ + (uint)get_group_id(0), \
         g##_end_ = (count); g < g##_end_; g += (uint)get_global_size(0) * TX_GRID_ROWS())

#endif
