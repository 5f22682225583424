// Logging to stderr: stdout carries exactly one JSON "ready" line, so nothing else may go there.
#pragma once

namespace cart2d {

enum class LogLevel { kError = 0, kWarn = 1, kInfo = 2, kDebug = 3 };

void set_log_level(LogLevel level);
LogLevel log_level();
void log_msg(LogLevel level, const char* fmt, ...) __attribute__((format(printf, 2, 3)));

}  // namespace cart2d

#define LOG_ERROR(...) ::cart2d::log_msg(::cart2d::LogLevel::kError, __VA_ARGS__)
#define LOG_WARN(...) ::cart2d::log_msg(::cart2d::LogLevel::kWarn, __VA_ARGS__)
#define LOG_INFO(...) ::cart2d::log_msg(::cart2d::LogLevel::kInfo, __VA_ARGS__)
#define LOG_DEBUG(...) ::cart2d::log_msg(::cart2d::LogLevel::kDebug, __VA_ARGS__)
