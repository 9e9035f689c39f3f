#line 2 "core/quadratic.h"
/* The quadratic a t^2 + 2 b t + c = 0 solved without cancellation (the stable pair of
 * Numerical Recipes 5.6 and of Haines et al., Ray Tracing Gems ch. 7): every
 * intersection that meets a quadratic (geometry/sphere.h, cylinder.h, quad.h and the
 * displaced surfaces' texel cells) takes its roots from here. b is HALF the linear
 * coefficient: no factor 4 in the discriminant, which could overflow. */
#ifndef TEXRAY_QUADRATIC_H
#define TEXRAY_QUADRATIC_H
#include "core/accurate.h"

/* The roots of a t^2 + 2 b t + c = 0 (b: half the linear coefficient), given root =
 * sqrt(b^2 - a c) computed by the caller as accurately as its geometry allows: q =
 * -(b + sign(b) root), then c/q and q/a, which never subtract nearly equal numbers
 * (|c/q| <= |q/a|); sorted. c_ok = 0 marks the root c/q, which is 0 when c is, as the
 * surface the ray starts on rather than a hit. */
typedef struct {
    float t_near, t_far;
    int near_ok, far_ok;
} QuadRoots;

static inline QuadRoots stable_roots(float a, float b, float c, float root, int c_ok)
{
    float q = -(b + copysign(root, b));
    float t_small = c / q, t_large = q / a;
    int small_first = t_small <= t_large;
    QuadRoots r = { small_first ? t_small : t_large, small_first ? t_large : t_small,
                    small_first ? c_ok : 1, small_first ? 1 : c_ok };
    return r;
}

/* b^2 - a c, a quarter of the discriminant of a t^2 + 2 b t + c, with relative error
 * <= 2u (core/accurate.h tx_diff_prod): nearly double roots (a ray near a curved
 * surface's silhouette) keep their accuracy, and the sign that decides hit or miss is
 * right. */
static inline float quadratic_disc(float a, float b, float c)
{
    return tx_diff_prod(b, b, a, c);
}

#endif
