#line 2 "texray.cl"
/* The whole program: texray.layout's generated declarations are prepended by
 * the host, then every stage. Stages are separate kernels so each can be
 * timed alone (texray bench). */
#include "common.h"
#include "sampler.h"
#include "geom.h"
#include "triangle.h"
#if TX_SPHERES
#include "sphere.h"
#endif
#if TX_CYLINDERS
#include "cylinder.h"
#endif
#if TX_QUADS
#include "quad.h"
#endif
#if TX_DISPLACEMENT
#include "displace.h"
#endif
#include "bvh.h"
#include "wrap.h"
#include "mapping.h"
#include "differentials.h"
#include "texture.h"
#if TX_BUMP || TX_NORMAL_MAPS || TX_VERTEX_NORMALS || TX_DISPLACEMENT
#include "bump.h"
#endif
#if TX_VERTEX_NORMALS
#include "terminator.h"
#endif
#include "raygen.cl"
#include "intersect.cl"
#include "surface.cl"
#include "shadow.cl"
#include "shade.cl"
#include "fused.cl"
