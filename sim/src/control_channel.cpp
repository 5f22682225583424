#include "control_channel.hpp"

#include <arpa/inet.h>   // htonl, htons, ntohs
#include <cerrno>        // errno
#include <cstring>       // strerror
#include <fcntl.h>       // fcntl
#include <netinet/in.h>  // sockaddr_in
#include <netinet/tcp.h> // TCP_NODELAY
#include <poll.h>        // pollfd
#include <sys/socket.h>  // socket, bind, accept4, send, recv
#include <unistd.h>      // close

#include <algorithm>     // std::remove_if

#include "log.hpp"

namespace cart2d {

constexpr size_t kMaxLine = 4u << 20;         // longest accepted input line (a world message with a 4000 × 4000 bitmap)
constexpr size_t kTruthBacklog = 1 << 20;     // above this, truth lines are skipped
constexpr size_t kHardBacklog = 16u << 20;    // above this, the client is disconnected

ControlChannel::~ControlChannel() {
  for (auto& c : clients_) close(c.fd);
  if (listen_fd_ >= 0) close(listen_fd_);
}

bool ControlChannel::listen(uint16_t port, std::string* error) {
  listen_fd_ = socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (listen_fd_ < 0) {
    *error = std::string("socket: ") + std::strerror(errno);
    return false;
  }
  const int one = 1;
  setsockopt(listen_fd_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  addr.sin_port = htons(port);
  if (bind(listen_fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0 || ::listen(listen_fd_, 8) != 0) {
    *error = "control port " + std::to_string(port) + ": " + std::strerror(errno);
    return false;
  }
  socklen_t len = sizeof addr;
  getsockname(listen_fd_, reinterpret_cast<sockaddr*>(&addr), &len);
  port_ = ntohs(addr.sin_port);
  return true;
}

ControlChannel::Client* ControlChannel::find(int client_id) {
  for (auto& c : clients_)
    if (c.id == client_id && !c.dead) return &c;
  return nullptr;
}

void ControlChannel::poll_input(double default_truth_hz, const std::function<void(int, const std::string&)>& handler) {
  for (;;) {
    const int fd = accept4(listen_fd_, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (fd < 0) break;
    const int one = 1;
    setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    Client c;
    c.id = next_id_++;
    c.fd = fd;
    c.truth_hz = default_truth_hz;
    clients_.push_back(std::move(c));
    LOG_INFO("control client %d connected", clients_.back().id);
  }
  // Index loop: a handler may queue output to any client but never adds clients.
  for (size_t i = 0; i < clients_.size(); ++i) {
    if (clients_[i].dead) continue;
    char buf[8192];
    for (;;) {
      const ssize_t n = recv(clients_[i].fd, buf, sizeof buf, 0);
      if (n > 0) {
        clients_[i].in.append(buf, static_cast<size_t>(n));
        continue;
      }
      if (n == 0 || (errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR)) clients_[i].dead = true;
      break;
    }
    size_t start = 0;
    for (;;) {
      const size_t nl = clients_[i].in.find('\n', start);
      if (nl == std::string::npos) break;
      std::string line = clients_[i].in.substr(start, nl - start);
      start = nl + 1;
      if (!line.empty() && line.back() == '\r') line.pop_back();
      if (line.find_first_not_of(" \t") == std::string::npos) continue;
      handler(clients_[i].id, line);
    }
    clients_[i].in.erase(0, start);
    if (clients_[i].in.size() > kMaxLine) {
      LOG_WARN("control client %d sent a line over %zu bytes: disconnected", clients_[i].id, kMaxLine);
      clients_[i].dead = true;
    }
  }
}

void ControlChannel::queue(Client& c, const std::string& line, bool droppable) {
  if (c.dead) return;
  if (droppable && c.out.size() > kTruthBacklog) {
    ++c.truth_dropped;
    return;
  }
  c.out += line;
  c.out.push_back('\n');
  if (c.out.size() > kHardBacklog) {
    LOG_WARN("control client %d does not read its messages: disconnected", c.id);
    c.dead = true;
  }
}

void ControlChannel::send(int client_id, const std::string& line, bool droppable) {
  if (Client* c = find(client_id)) queue(*c, line, droppable);
}

void ControlChannel::broadcast(const std::string& line, bool droppable) {
  for (auto& c : clients_) queue(c, line, droppable);
}

void ControlChannel::flush() {
  for (auto& c : clients_) {
    while (!c.dead && !c.out.empty()) {
      const ssize_t n = ::send(c.fd, c.out.data(), c.out.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
      if (n > 0) {
        c.out.erase(0, static_cast<size_t>(n));
        continue;
      }
      if (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR) c.dead = true;
      break;
    }
  }
  for (auto& c : clients_) {
    if (c.dead && c.fd >= 0) {
      LOG_INFO("control client %d disconnected", c.id);
      close(c.fd);
      c.fd = -1;
    }
  }
  clients_.erase(std::remove_if(clients_.begin(), clients_.end(), [](const Client& c) { return c.dead; }), clients_.end());
}

void ControlChannel::add_poll_fds(std::vector<pollfd>* fds) const {
  if (listen_fd_ >= 0) fds->push_back({listen_fd_, POLLIN, 0});
  for (const auto& c : clients_)
    if (!c.dead) fds->push_back({c.fd, static_cast<short>(POLLIN | (c.out.empty() ? 0 : POLLOUT)), 0});
}

}  // namespace cart2d
