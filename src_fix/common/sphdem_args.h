/* sphdem_args.h - keyword parsing shared by the fix styles: a number that names its keyword, and a keyword
 * whose value is one of a list of names. The helpers report through the fix's fail(msg), passed as a
 * callable that ends the run. */
#ifndef SPHDEM_ARGS_H
#define SPHDEM_ARGS_H

#include <initializer_list>
#include <string>
#include <utility>

#include "sphdem_compat.h"

namespace sphdem_args {

/* all of s as a number, else "KW expects a number, got 'S' (usage: USAGE)" */
template <class Fail> double number(Fail fail, const char *kw, const char *s, const char *usage) {
  double v = 0.0;
  if (!sphdem_compat::to_double(s, &v))
    fail(std::string(kw) + " expects a number, got '" + (s ? s : "") + "' (usage: " + usage + ")");
  return v;
}

/* The value after keyword kw (arg[iarg + 1]) as one of names: the number it maps to. "KW must be ALLOWED"
 * when the value is missing, the same with " (got 'V')" when it is none of the names. */
template <class Fail>
int choice(Fail fail, const std::string &kw, int iarg, int narg, char **arg,
           std::initializer_list<std::pair<const char *, int>> names, const std::string &allowed) {
  if (iarg + 1 >= narg) fail(kw + " must be " + allowed);
  const std::string v = arg[iarg + 1];
  for (const auto &n : names)
    if (v == n.first) return n.second;
  fail(kw + " must be " + allowed + " (got '" + v + "')");
  return 0; /* not reached */
}

/* yes or no: 1 or 0 */
template <class Fail> int yes_no(Fail fail, const std::string &kw, int iarg, int narg, char **arg) {
  return choice(fail, kw, iarg, narg, arg, {{"yes", 1}, {"no", 0}}, "yes or no");
}

}  // namespace sphdem_args

#endif
