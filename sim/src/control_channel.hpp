// The side channel: JSON lines over TCP on 127.0.0.1, any number of clients, every socket
// non-blocking and polled from the simulation thread (so only that thread ever touches the MCU).
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "robot_params.hpp"  // params::sim

struct pollfd;

namespace cart2d {

class ControlChannel {
 public:
  struct Client {
    int id = 0;
    int fd = -1;
    std::string in;
    std::string out;
    double truth_hz = params::sim::truth_hz;
    uint64_t next_truth_cycle = 0;
    uint64_t truth_dropped = 0;  // truth lines skipped because the client fell behind
    bool dead = false;
  bool camera = false;  // receives the simulated camera's frames
  };

  ControlChannel() = default;
  ~ControlChannel();
  ControlChannel(const ControlChannel&) = delete;
  ControlChannel& operator=(const ControlChannel&) = delete;

  // Listens on 127.0.0.1:port (0 = any free port).
  bool listen(uint16_t port, std::string* error);
  uint16_t port() const { return port_; }

  // Accepts new clients and hands every complete input line to handler(client id, line).
  // New clients start with truth_hz = default_truth_hz.
  void poll_input(double default_truth_hz, const std::function<void(int, const std::string&)>& handler);
  // Queues one line (a newline is added). Droppable lines (ground truth) are skipped for a client
  // whose backlog is already large, so a slow reader never stalls the simulation.
  void send(int client_id, const std::string& line, bool droppable = false);
  void broadcast(const std::string& line, bool droppable = false);
  // Writes queued output without blocking and forgets disconnected clients.
  void flush();
  void add_poll_fds(std::vector<pollfd>* fds) const;

  std::vector<Client>& clients() { return clients_; }
  Client* find(int client_id);

 private:
  void queue(Client& c, const std::string& line, bool droppable);

  int listen_fd_ = -1;
  uint16_t port_ = 0;
  int next_id_ = 1;
  std::vector<Client> clients_;
};

}  // namespace cart2d
