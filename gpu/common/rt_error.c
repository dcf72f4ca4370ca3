/* rt_error.c - the error text of the device runtime (rt->err), written by every context and backend; the
 * bottom of the core's call graph (it calls nothing of the core). */
#include <stdio.h>

#include "runtime.h"

int sphdem_rt_vfail(sphdem_rt *rt, int code, const char *fmt, va_list ap) {
  if (rt) vsnprintf(rt->err, sizeof rt->err, fmt, ap);
  return code;
}

int sphdem_rt_fail(sphdem_rt *rt, int code, const char *fmt, ...) {
  va_list ap;
  va_start(ap, fmt);
  code = sphdem_rt_vfail(rt, code, fmt, ap);
  va_end(ap);
  return code;
}
