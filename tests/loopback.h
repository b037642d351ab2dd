// A free TCP port on the loopback interface, for a daemon a test or benchmark starts as a
// process (tests/memory_admission_test.cc, bench/soak_bench.cc): the kernel picks it, the socket
// is closed, and the daemon binds it next (another process could take it in between; nothing else
// on the machine binds ephemeral ports explicitly). 0 when none could be had.
#ifndef SHRM_TESTS_LOOPBACK_H_
#define SHRM_TESTS_LOOPBACK_H_

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

namespace shrm::testing {

inline int FreeLoopbackPort() {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return 0;
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t len = sizeof a;
  int port = 0;
  if (bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0 &&
      getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len) == 0) {
    port = ntohs(a.sin_port);
  }
  close(fd);
  return port;
}

}  // namespace shrm::testing

#endif  // SHRM_TESTS_LOOPBACK_H_
