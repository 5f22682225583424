// The simulated Nano's USB serial port as the host sees it: a pseudo-terminal of which we hold
// only the master side. While no process has the slave open, poll() on the master reports
// POLLHUP (and read() gives EIO); a process opening the slave ends it. That is how we see the
// host open the port, the moment a USB-serial adapter raises DTR, which resets a Nano.
// A close and a reopen between two looks leave no trace there, so where inotify works its
// IN_OPEN/IN_CLOSE on the slave's device file tell instead (a host that closes and at once
// reopens its port drops and raises DTR all the same).
#pragma once

#include <string>
#include <vector>

namespace cart2d {

class PtyPort {
 public:
  // What happened since the last look, in order: the port going from nobody to somebody
  // having it open (kOpened), and back (kClosed).
  enum class Change { kOpened, kClosed };

  PtyPort() = default;
  ~PtyPort();
  PtyPort(const PtyPort&) = delete;
  PtyPort& operator=(const PtyPort&) = delete;

  // A raw-mode pty (the settings stay with the pty across opens); nobody has it open after.
  bool open(std::string* error);
  bool is_open() const { return master_fd_ >= 0; }
  const std::string& path() const { return path_; }
  int fd() const { return master_fd_; }
  // Readable when a host opened or closed the port (-1 without inotify): worth a wake-up.
  int change_fd() const { return inotify_fd_; }

  std::vector<Change> poll_host();
  bool host_attached() const { return attached_; }

  // Appends what the host wrote, including what a host that has just closed left behind.
  void read(std::string* in);
  // Writes what the pty takes and erases it from *out.
  void write(std::string* out);

 private:
  int master_fd_ = -1;
  int inotify_fd_ = -1;  // -1: only POLLHUP is looked at
  std::string path_;
  bool attached_ = false;
};

}  // namespace cart2d
