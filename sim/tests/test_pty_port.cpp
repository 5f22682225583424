// The pseudo-terminal as the host's serial port: every open by a host is seen, even a close and
// a reopen between two looks (each is a DTR edge that resets a Nano), and bytes pass both ways.
#include <gtest/gtest.h>

#include <fcntl.h>   // open
#include <unistd.h>  // close, read, write

#include <string>
#include <vector>

#include "pty_port.hpp"

namespace cart2d {
namespace {

using Change = PtyPort::Change;

int open_as_host(const std::string& path) { return ::open(path.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK); }

TEST(PtyPort, SeesEveryOpenAndClose) {
  PtyPort port;
  std::string error;
  ASSERT_TRUE(port.open(&error)) << error;
  EXPECT_TRUE(port.poll_host().empty());
  EXPECT_FALSE(port.host_attached());

  const int a = open_as_host(port.path());
  ASSERT_GE(a, 0);
  EXPECT_EQ(port.poll_host(), std::vector<Change>{Change::kOpened});
  EXPECT_TRUE(port.host_attached());
  EXPECT_TRUE(port.poll_host().empty());

  ::close(a);
  const int b = open_as_host(port.path());  // closed and reopened before the next look
  ASSERT_GE(b, 0);
  EXPECT_EQ(port.poll_host(), (std::vector<Change>{Change::kClosed, Change::kOpened}));

  ::close(b);
  EXPECT_EQ(port.poll_host(), std::vector<Change>{Change::kClosed});
  EXPECT_FALSE(port.host_attached());
}

TEST(PtyPort, BytesPassBothWaysAndWhatAClosingHostWroteIsRead) {
  PtyPort port;
  std::string error;
  ASSERT_TRUE(port.open(&error)) << error;
  const int host = open_as_host(port.path());
  ASSERT_GE(host, 0);
  port.poll_host();
  std::string out = "to host";
  port.write(&out);
  EXPECT_TRUE(out.empty());
  char buf[16] = {0};
  EXPECT_EQ(::read(host, buf, sizeof buf), 7);
  EXPECT_EQ(std::string(buf, 7), "to host");
  ASSERT_EQ(::write(host, "bye", 3), 3);
  ::close(host);
  std::string in;
  port.read(&in);
  EXPECT_EQ(in, "bye");
}

}  // namespace
}  // namespace cart2d
