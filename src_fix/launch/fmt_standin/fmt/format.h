/* fmt/format.h - declaration-only stand-in for the fmt 7 headers that Debian's liblammps-dev
 * does not ship (LAMMPS bundles fmt in the inline namespace fmt::v7_lmp). It lets pointers.h,
 * utils.h and error.h compile; the fmt-templated overloads of error->all/one and
 * utils::logmesg must never be instantiated: use the std::string overloads (sphdem_compat.h). */
#ifndef SPHDEM_FMT_STANDIN_H
#define SPHDEM_FMT_STANDIN_H
#include <string>

namespace fmt {
inline namespace v7_lmp {
template <typename Char> class basic_string_view;
using string_view = basic_string_view<char>;
class format_args;
/* never defined: instantiating it is a link error by design */
template <typename... Args, typename S> format_args make_args_checked(const S &, const Args &...);
}  // namespace v7_lmp
}  // namespace fmt
#endif
