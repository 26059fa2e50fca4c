/* Entry points of fmucal's example FMUs; see fmu_framework.h. The Co-Simulation integrator
 * (fmu_cosim.c) is the same in every build that offers Co-Simulation; the exported API is FMI 2.0's
 * (fmu_framework2.c) by default, FMI 3.0's (fmu_framework3.c) with FMUCAL_FMI3 and FMI 1.0's
 * (fmu_framework1.c) with FMUCAL_FMI1 = 1 (Model Exchange) or 2 (Co-Simulation). */

#define STATE(k) (m->r[STATE_VR[(k)]])
#define DERIV(k) (m->r[DER_VR[(k)]])

#if !(defined(FMUCAL_FMI1) && FMUCAL_FMI1 == 1) /* every build but FMI 1.0 Model Exchange */
#include "fmu_cosim.c"
#endif
#if defined(FMUCAL_FMI3)
#include "fmu_framework3.c"
#elif defined(FMUCAL_FMI1)
#include "fmu_framework1.c"
#else
#include "fmu_framework2.c"
#endif
