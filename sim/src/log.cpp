#include "log.hpp"

#include <cstdarg>  // va_list
#include <cstdio>   // vfprintf

namespace cart2d {

static LogLevel g_level = LogLevel::kInfo;

void set_log_level(LogLevel level) { g_level = level; }
LogLevel log_level() { return g_level; }

void log_msg(LogLevel level, const char* fmt, ...) {
  if (level > g_level) return;
  static const char* const kNames[] = {"error", "warn", "info", "debug"};
  std::fprintf(stderr, "cart2d-sim %s: ", kNames[static_cast<int>(level)]);
  va_list ap;
  va_start(ap, fmt);
  std::vfprintf(stderr, fmt, ap);
  va_end(ap);
  std::fputc('\n', stderr);
}

}  // namespace cart2d
