/* lammpsplugin_decl.h - the plugin record of LAMMPS' PLUGIN package, declared as documented
 * (docs.lammps.org/Developer_plugins.html) because Debian's liblammps-dev ships no lammpsplugin.h. */
#ifndef SPHDEM_LAMMPSPLUGIN_DECL_H
#define SPHDEM_LAMMPSPLUGIN_DECL_H

extern "C" {
typedef void *(lammpsplugin_factory1)(void *);
typedef void *(lammpsplugin_factory2)(void *, int, char **);
typedef struct {
  const char *version;
  const char *style;
  const char *name;
  const char *info;
  const char *author;
  union {
    lammpsplugin_factory1 *v1;
    lammpsplugin_factory2 *v2;
  } creator;
  void *handle;
} lammpsplugin_t;
typedef void (*lammpsplugin_regfunc)(lammpsplugin_t *, void *);
typedef void (*lammpsplugin_initfunc)(void *, void *, void *);
}

#endif
