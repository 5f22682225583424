#include "pty_port.hpp"

#include <cerrno>     // errno
#include <cstring>    // strerror
#include <fcntl.h>    // fcntl, O_NONBLOCK
#include <poll.h>     // poll, POLLHUP
#include <pty.h>      // openpty
#include <termios.h>  // cfmakeraw, tcsetattr
#include <unistd.h>   // read, write, close

namespace cart2d {

PtyPort::~PtyPort() {
  if (master_fd_ >= 0) close(master_fd_);
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
  return true;
}

PtyPort::Change PtyPort::poll_host() {
  if (master_fd_ < 0) return Change::kNone;
  pollfd p = {master_fd_, POLLIN, 0};
  if (poll(&p, 1, 0) < 0) return Change::kNone;
  const bool attached = !(p.revents & POLLHUP);
  if (attached == attached_) return Change::kNone;
  attached_ = attached;
  return attached ? Change::kOpened : Change::kClosed;
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
