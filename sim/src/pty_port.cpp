#include "pty_port.hpp"

#include <cerrno>     // errno
#include <cstring>    // strerror
#include <fcntl.h>    // fcntl, O_NONBLOCK
#include <poll.h>     // poll, POLLHUP
#include <pty.h>      // openpty
#include <sys/inotify.h>  // inotify_init1, inotify_add_watch
#include <termios.h>  // cfmakeraw, tcsetattr
#include <unistd.h>   // read, write, close

namespace cart2d {

PtyPort::~PtyPort() {
  if (master_fd_ >= 0) close(master_fd_);
  if (inotify_fd_ >= 0) close(inotify_fd_);
}

bool PtyPort::open(std::string* error) {
  char name[256] = {0};
  int slave_fd = -1;
  if (openpty(&master_fd_, &slave_fd, name, nullptr, nullptr) != 0) {
    *error = std::string("openpty: ") + std::strerror(errno);
    return false;
  }
  // Raw, so that a client that sets nothing gets the bytes unchanged; the baud setting is
  // only a label (the line's timing is simulated).
  termios tio;
  tcgetattr(slave_fd, &tio);
  cfmakeraw(&tio);
  cfsetispeed(&tio, B115200);
  cfsetospeed(&tio, B115200);
  tcsetattr(slave_fd, TCSANOW, &tio);
  close(slave_fd);  // from now on an open of the slave is a host opening the port
  fcntl(master_fd_, F_SETFL, fcntl(master_fd_, F_GETFL) | O_NONBLOCK);
  fcntl(master_fd_, F_SETFD, FD_CLOEXEC);
  path_ = name;
  attached_ = false;
  inotify_fd_ = inotify_init1(IN_NONBLOCK | IN_CLOEXEC);
  if (inotify_fd_ >= 0 && inotify_add_watch(inotify_fd_, name, IN_OPEN | IN_CLOSE) < 0) {
    close(inotify_fd_);
    inotify_fd_ = -1;
  }
  return true;
}

// With inotify, its events alone tell the story: IN_CLOSE comes before the slave is released,
// so POLLHUP may still say "open" right after it. inotify merges identical events in a row,
// which only hides an open or a close by a second process while another holds the port: no
// DTR edge there. Without inotify, POLLHUP at each look is all there is.
std::vector<PtyPort::Change> PtyPort::poll_host() {
  std::vector<Change> changes;
  if (master_fd_ < 0) return changes;
  auto to = [&](bool open) {
    if (open != attached_) changes.push_back(open ? Change::kOpened : Change::kClosed);
    attached_ = open;
  };
  if (inotify_fd_ >= 0) {
    alignas(inotify_event) char buf[4096];
    for (ssize_t n; (n = ::read(inotify_fd_, buf, sizeof buf)) > 0;) {
      for (char* p = buf; p < buf + n;) {
        const auto* e = reinterpret_cast<const inotify_event*>(p);
        if (e->mask & IN_OPEN) to(true);
        if (e->mask & IN_CLOSE) to(false);
        p += sizeof(inotify_event) + e->len;
      }
    }
    return changes;
  }
  pollfd p = {master_fd_, POLLIN, 0};
  if (poll(&p, 1, 0) >= 0) to(!(p.revents & POLLHUP));
  return changes;
}

void PtyPort::read(std::string* in) {
  if (master_fd_ < 0) return;
  char buf[4096];
  for (;;) {
    const ssize_t n = ::read(master_fd_, buf, sizeof buf);
    if (n <= 0) return;  // EAGAIN: nothing more; EIO: nobody has the port open
    in->append(buf, static_cast<size_t>(n));
  }
}

void PtyPort::write(std::string* out) {
  if (master_fd_ < 0) return;
  while (!out->empty()) {
    const ssize_t n = ::write(master_fd_, out->data(), out->size());
    if (n <= 0) return;
    out->erase(0, static_cast<size_t>(n));
  }
}

}  // namespace cart2d
