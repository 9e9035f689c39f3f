#line 2 "texray.cl"
/* The whole program: texray.layout's generated declarations are prepended by
 * the host, then every stage. Stages are separate kernels so each can be
 * timed alone (texray bench). */
#include "common.h"
#include "sampler.h"
#include "triangle.h"
#include "bvh.h"
#include "texture.h"
#include "raygen.cl"
#include "intersect.cl"
#include "surface.cl"
#include "shadow.cl"
#include "shade.cl"
