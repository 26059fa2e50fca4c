/* Entry points of fmucal's example FMUs; see fmu_framework.h. The Co-Simulation integrator
 * (fmu_cosim.c) is the same in every build; the exported API is FMI 2.0's
 * (fmu_framework2.c) by default and FMI 3.0's (fmu_framework3.c) with FMUCAL_FMI3. */

#define STATE(k) (m->r[STATE_VR[(k)]])
#define DERIV(k) (m->r[DER_VR[(k)]])

#include "fmu_cosim.c"
#if defined(FMUCAL_FMI3)
#include "fmu_framework3.c"
#else
#include "fmu_framework2.c"
#endif
