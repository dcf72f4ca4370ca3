/* sphdem_register.h - registers every sphdem style with one engine instance (launchers, plugin). */
#ifndef SPHDEM_REGISTER_H
#define SPHDEM_REGISTER_H

namespace LAMMPS_NS {
class LAMMPS;
}

/* Insert the creators of all sphdem styles into lmp's style maps. Call before input is read. */
void sphdem_register_styles(LAMMPS_NS::LAMMPS *lmp);

#endif
