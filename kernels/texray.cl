#line 2 "texray.cl"
/* The whole program: texray.layout's generated declarations are prepended by
 * the host, then every stage. Stages are separate kernels so each can be
 * timed alone (texray bench). */
#include "core/common.h"
#include "core/sampler.h"
#include "core/accurate.h"
#include "geometry/triangle.h"
#if TX_SPHERES
#include "geometry/sphere.h"
#endif
#if TX_CYLINDERS
#include "geometry/cylinder.h"
#endif
#if TX_QUADS
#include "geometry/quad.h"
#endif
#if TX_DISPLACEMENT
#include "geometry/displace.h"
#endif
#include "accel/bvh.h"
#include "texture/wrap.h"
#include "texture/mapping.h"
#include "texture/differentials.h"
#include "texture/texture.h"
#if TX_BUMP || TX_NORMAL_MAPS || TX_VERTEX_NORMALS || TX_DISPLACEMENT
#include "shading/bump.h"
#endif
#if TX_VERTEX_NORMALS
#include "shading/terminator.h"
#endif
#include "stages/raygen.cl"
#include "stages/intersect.cl"
#include "stages/surface.cl"
#include "stages/shadow.cl"
#include "stages/shade.cl"
#include "stages/fused.cl"
