#include "dashboard_server.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <fcntl.h>
#include <poll.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <map>
#include <stdexcept>
#include <vector>

#include <fmt/format.h>

#include "cpgmatch/errors.hpp"
#include "web_assets.hpp"

namespace cpgmatch::cli::dashboard {

namespace {

// Numeric address for the socket calls; "localhost" is the one name accepted (the loopback, IPv4).
std::string numeric(const std::string& address) { return address == "localhost" ? "127.0.0.1" : address; }

// The family of a numeric IPv4 or IPv6 address, or nullopt for anything else.
std::optional<int> family_of(const std::string& address) {
  in6_addr v6{};
  in_addr v4{};
  if (inet_pton(AF_INET, address.c_str(), &v4) == 1) return AF_INET;
  if (inet_pton(AF_INET6, address.c_str(), &v6) == 1) return AF_INET6;
  return std::nullopt;
}

// Why `address`:`port` cannot be bound, in the words of the flag at fault. httplib says only that binding
// failed, so the bind is tried once more here to read errno.
InputError bind_error(const std::string& address, int port) {
  const int family = *family_of(address);
  const int fd = ::socket(family, SOCK_STREAM, 0);
  int error = 0;
  if (fd < 0) {
    error = errno;
  } else {
    sockaddr_storage storage{};
    socklen_t length = 0;
    if (family == AF_INET) {
      auto* a = reinterpret_cast<sockaddr_in*>(&storage);
      a->sin_family = AF_INET;
      a->sin_port = htons(static_cast<std::uint16_t>(port));
      inet_pton(AF_INET, address.c_str(), &a->sin_addr);
      length = sizeof(sockaddr_in);
    } else {
      auto* a = reinterpret_cast<sockaddr_in6*>(&storage);
      a->sin6_family = AF_INET6;
      a->sin6_port = htons(static_cast<std::uint16_t>(port));
      inet_pton(AF_INET6, address.c_str(), &a->sin6_addr);
      length = sizeof(sockaddr_in6);
    }
    if (::bind(fd, reinterpret_cast<sockaddr*>(&storage), length) != 0) error = errno;
    ::close(fd);
  }
  switch (error) {
    case EADDRINUSE:
      return InputError(fmt::format("--port {}: already in use on {} (another dashboard?); choose another port, or "
                                    "--port 0 for any free one", port, address));
    case EADDRNOTAVAIL:
      return InputError(fmt::format("--bind {}: not an address of this machine", address));
    case EACCES:
      return InputError(fmt::format("--port {}: not allowed for this user (ports below 1024 need privileges)", port));
    default:
      return InputError(fmt::format("--bind {} --port {}: cannot listen there ({})", address, port,
                                    error ? std::strerror(error) : "the server refused it"));
  }
}

}  // namespace

void SnapshotFeed::publish(std::string json_text) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (latest_.version > 0 && latest_.json == json_text) return;
    latest_.json = std::move(json_text);
    shared_ = std::make_shared<const std::string>(latest_.json);
    ++latest_.version;
  }
  changed_.notify_all();
}

SnapshotFeed::Snapshot SnapshotFeed::latest() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return latest_;
}

std::optional<SnapshotFeed::Snapshot> SnapshotFeed::wait_newer(std::uint64_t seen,
                                                               std::chrono::milliseconds timeout) const {
  std::unique_lock<std::mutex> lock(mutex_);
  if (!changed_.wait_for(lock, timeout, [&] { return closed_ || latest_.version > seen; }) || closed_) {
    return std::nullopt;
  }
  return latest_;
}

void SnapshotFeed::close() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    closed_ = true;
  }
  changed_.notify_all();
}

bool SnapshotFeed::closed() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return closed_;
}

std::pair<std::uint64_t, std::shared_ptr<const std::string>> SnapshotFeed::latest_shared() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return {latest_.version, shared_};
}

bool is_loopback(const std::string& address) {
  const std::string a = numeric(address);
  in_addr v4{};
  if (inet_pton(AF_INET, a.c_str(), &v4) == 1) return (ntohl(v4.s_addr) >> 24) == 127;
  in6_addr v6{};
  return inet_pton(AF_INET6, a.c_str(), &v6) == 1 && IN6_IS_ADDR_LOOPBACK(&v6);
}

namespace {

using Clock = std::chrono::steady_clock;

// Headers every answer carries: study data only (served unauthenticated): no caching, nothing but this
// server's own files and data: images, and no sniffing a type.
constexpr const char* kCommonHeaders =
    "Cache-Control: no-store\r\n"
    "X-Content-Type-Options: nosniff\r\n"
    "Content-Security-Policy: default-src 'self'; img-src 'self' data:; style-src 'self'; script-src 'self'; "
    "connect-src 'self'; frame-ancestors 'none'\r\n";

const char* reason_of(int status) {
  switch (status) {
    case 200: return "OK";
    case 400: return "Bad Request";
    case 404: return "Not Found";
    case 405: return "Method Not Allowed";
    case 408: return "Request Timeout";
    case 431: return "Request Header Fields Too Large";
    case 503: return "Service Unavailable";
    default: return "Error";
  }
}

// A whole answer that ends the connection: head, then the body (shared, never copied) unless HEAD.
struct Answer {
  std::string head;
  std::shared_ptr<const std::string> body;
};

Answer answer(int status, const std::string& type, std::shared_ptr<const std::string> body, bool head_only,
              const std::string& extra = "") {
  Answer a;
  a.head = fmt::format("HTTP/1.1 {} {}\r\nContent-Type: {}\r\nContent-Length: {}\r\n{}{}Connection: close\r\n\r\n",
                       status, reason_of(status), type, body ? body->size() : 0, kCommonHeaders, extra);
  if (!head_only) a.body = std::move(body);
  return a;
}

Answer plain(int status, const std::string& text, bool head_only = false, const std::string& extra = "") {
  return answer(status, "text/plain; charset=utf-8", std::make_shared<const std::string>(text + "\n"), head_only, extra);
}

// One chunk of a chunked body (the event stream's framing).
std::string chunk(const std::string& data) { return fmt::format("{:x}\r\n{}\r\n", data.size(), data); }

struct Connection {
  int fd = -1;
  std::string address;
  Clock::time_point opened, last_progress;
  std::string in;  // the request head so far
  enum class Phase { kReading, kWriting, kStreaming, kDraining } phase = Phase::kReading;
  // What is left to write: `out` first, then `body` from `body_at`.
  std::string out;
  std::shared_ptr<const std::string> body;
  std::size_t body_at = 0;
  std::uint64_t seen = 0;  // event stream: the snapshot version sent last
  bool counted_stream = false;  // counted in streams_per_address
  bool counted_address = true;  // counted in per_address (until answered: a drained one no longer counts)
  Clock::time_point last_event;
  Clock::time_point drain_until;

  bool pending() const { return !out.empty() || (body && body_at < body->size()); }
};

std::string peer_address(const sockaddr_storage& peer) {
  char text[INET6_ADDRSTRLEN] = "?";
  if (peer.ss_family == AF_INET) {
    inet_ntop(AF_INET, &reinterpret_cast<const sockaddr_in*>(&peer)->sin_addr, text, sizeof(text));
  } else if (peer.ss_family == AF_INET6) {
    inet_ntop(AF_INET6, &reinterpret_cast<const sockaddr_in6*>(&peer)->sin6_addr, text, sizeof(text));
  }
  return text;
}

}  // namespace

struct DashboardServer::Impl {
  const SnapshotFeed& feed;
  std::shared_ptr<const std::string> chartjs;
  ServerLimits limits;
  std::map<std::string, std::pair<std::string, std::shared_ptr<const std::string>>> assets;  // path -> type, body
  int listener = -1;
  std::atomic<bool> stopping{false};
  std::vector<Connection> connections;
  std::map<std::string, std::size_t> per_address, streams_per_address;

  Impl(const SnapshotFeed& f, std::string chart, ServerLimits l)
      : feed(f), chartjs(std::make_shared<const std::string>(std::move(chart))), limits(l) {
    for (const web::Asset& asset : web::dashboard_assets()) {
      assets[std::string(asset.path)] = {std::string(asset.content_type), std::make_shared<const std::string>(asset.body)};
    }
    assets["/chart.js"] = {"text/javascript", chartjs};
  }
  ~Impl() {
    for (auto& c : connections) ::close(c.fd);
    if (listener >= 0) ::close(listener);
  }

  void finish_with(Connection& c, Answer a) {
    c.out = std::move(a.head);
    c.body = std::move(a.body);
    c.body_at = 0;
    c.phase = Connection::Phase::kWriting;
    c.last_progress = Clock::now();
  }

  // Refuses a connection over a limit with a 503 naming it, written at once (best effort: the socket's buffer
  // takes a short answer whole) and closed.
  void refuse(int fd, const std::string& why) {
    const Answer a = plain(503, "503 " + why);
    const std::string all = a.head + *a.body;
    (void)::send(fd, all.data(), all.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
    ::shutdown(fd, SHUT_WR);
    ::close(fd);
  }

  void accept_all() {
    while (true) {
      sockaddr_storage peer{};
      socklen_t length = sizeof(peer);
      const int fd = ::accept4(listener, reinterpret_cast<sockaddr*>(&peer), &length, SOCK_NONBLOCK | SOCK_CLOEXEC);
      if (fd < 0) return;  // EAGAIN (nothing more), or EMFILE and the like: the next round tries again
      const std::string address = peer_address(peer);
      if (connections.size() >= limits.max_connections) {
        refuse(fd, fmt::format("the dashboard has {} connections open, its limit; try again shortly",
                               connections.size()));
        continue;
      }
      if (per_address[address] >= limits.max_connections_per_address) catch_up(address);
      if (per_address[address] >= limits.max_connections_per_address) {
        refuse(fd, fmt::format("{} connections from {} are open, the limit for one address", per_address[address], address));
        continue;
      }
      ++per_address[address];
      Connection c;
      c.fd = fd;
      c.address = address;
      c.opened = c.last_progress = Clock::now();
      // Served at once, before the next accept: a request that has already arrived is answered (or refused)
      // now, so that connections which are only waiting to be told 503 do not count against their address
      // while later connections are accepted (500 tabs from one address left none for its next request).
      if (advance(c, POLLIN, c.opened)) {
        release_address(c);
        ::close(c.fd);
        continue;
      }
      connections.push_back(std::move(c));
    }
  }

  // Parses the request head once it is whole; answers what is wrong as soon as it can be seen.
  void read_request(Connection& c) {
    char buf[4096];
    while (c.phase == Connection::Phase::kReading) {
      const ssize_t n = ::recv(c.fd, buf, sizeof(buf), 0);
      if (n == 0) {
        c.phase = Connection::Phase::kDraining;  // the client gave up: close
        c.drain_until = Clock::now();
        return;
      }
      if (n < 0) {
        if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) return;
        c.phase = Connection::Phase::kDraining;
        c.drain_until = Clock::now();
        return;
      }
      c.in.append(buf, static_cast<std::size_t>(n));
      // The request line: METHOD SP TARGET SP HTTP/1.x, printable ASCII. Anything else is refused as soon as
      // it is seen, not after a timeout.
      const std::size_t line_end = c.in.find("\r\n");
      const std::string_view line = std::string_view(c.in).substr(0, line_end == std::string::npos ? c.in.size() : line_end);
      for (const char ch : line) {
        if (static_cast<unsigned char>(ch) < 0x20 || static_cast<unsigned char>(ch) > 0x7E) {
          finish_with(c, plain(400, "400 not an HTTP request"));
          return;
        }
      }
      if (line_end != std::string::npos) {
        const std::size_t a = line.find(' '), b = line.rfind(' ');
        if (a == std::string_view::npos || a == b || line.substr(b + 1, 7) != "HTTP/1." || line.size() != b + 9) {
          finish_with(c, plain(400, "400 not an HTTP/1 request line"));
          return;
        }
      }
      const std::size_t head_end = c.in.find("\r\n\r\n");
      if (head_end == std::string::npos) {
        if (c.in.size() > limits.max_request_head_bytes) {
          finish_with(c, plain(431, fmt::format("431 the request head is longer than {} bytes", limits.max_request_head_bytes)));
        }
        continue;
      }
      const std::size_t a = line.find(' '), b = line.rfind(' ');
      const std::string method(line.substr(0, a));
      std::string target(line.substr(a + 1, b - a - 1));
      if (const std::size_t q = target.find('?'); q != std::string::npos) target.resize(q);
      route(c, method, target);
      return;
    }
  }

  void route(Connection& c, const std::string& method, const std::string& target) {
    if (method != "GET" && method != "HEAD") {
      finish_with(c, plain(405, "read-only: GET and HEAD only", false, "Allow: GET, HEAD\r\n"));
      return;
    }
    const bool head_only = method == "HEAD";
    if (target == "/api/snapshot") {
      finish_with(c, answer(200, "application/json", feed.latest_shared().second, head_only));
      return;
    }
    if (target == "/events") {
      if (streams_per_address[c.address] >= limits.max_streams_per_address) {
        finish_with(c, plain(503, fmt::format("503 {} event streams from {} are open, the limit for one address; "
                                              "close a dashboard tab", streams_per_address[c.address], c.address)));
        return;
      }
      c.out = fmt::format("HTTP/1.1 200 OK\r\nContent-Type: text/event-stream\r\nTransfer-Encoding: chunked\r\n{}\r\n",
                          kCommonHeaders);
      if (head_only) {
        finish_with(c, Answer{c.out, nullptr});
        return;
      }
      ++streams_per_address[c.address];
      c.counted_stream = true;
      c.phase = Connection::Phase::kStreaming;
      c.last_event = c.last_progress = Clock::now();
      return;
    }
    const auto it = assets.find(target);
    if (it == assets.end()) {
      finish_with(c, plain(404, "404 no such page", head_only));
      return;
    }
    finish_with(c, answer(200, it->second.first, it->second.second, head_only));
  }

  // Writes what the socket takes; false when the connection failed.
  bool write_some(Connection& c) {
    while (c.pending()) {
      const char* data = nullptr;
      std::size_t size = 0;
      if (!c.out.empty()) {
        data = c.out.data();
        size = c.out.size();
      } else {
        data = c.body->data() + c.body_at;
        size = c.body->size() - c.body_at;
      }
      const ssize_t n = ::send(c.fd, data, size, MSG_NOSIGNAL | MSG_DONTWAIT);
      if (n < 0) return errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR;
      c.last_progress = Clock::now();
      if (!c.out.empty()) {
        c.out.erase(0, static_cast<std::size_t>(n));
      } else {
        c.body_at += static_cast<std::size_t>(n);
      }
    }
    if (c.body && c.body_at >= c.body->size()) c.body.reset();
    return true;
  }

  // An event stream with nothing left to send gets the newest snapshot (or a keep-alive comment).
  void feed_stream(Connection& c, std::uint64_t version, const std::shared_ptr<const std::string>& json, bool closing) {
    if (c.pending()) return;
    if (closing) {
      c.out = "0\r\n\r\n";  // the chunked body's end
      c.phase = Connection::Phase::kWriting;
      return;
    }
    const auto now = Clock::now();
    if (version > c.seen && json) {
      // A JSON dump has no raw newline, so the whole snapshot is one data line.
      c.out = chunk(fmt::format("{}event: snapshot\ndata: {}\n\n", c.seen == 0 ? "retry: 2000\n" : "", *json));
      c.seen = version;
      c.last_event = now;
    } else if (now - c.last_event > limits.keep_alive) {
      c.out = chunk(": keep-alive\n\n");
      c.last_event = now;
    }
  }

  void release_address(Connection& c) {
    if (c.counted_stream) {
      if (auto it = streams_per_address.find(c.address); it != streams_per_address.end() && it->second > 0) --it->second;
      c.counted_stream = false;
    }
    if (c.counted_address) {
      if (auto it = per_address.find(c.address); it != per_address.end() && --it->second == 0) per_address.erase(it);
      c.counted_address = false;
    }
  }

  void close_connection(std::size_t i) {
    Connection& c = connections[i];
    release_address(c);
    ::close(c.fd);
    connections[i] = std::move(connections.back());
    connections.pop_back();
  }

  // Before an address is refused for its number of connections: serves those of its connections whose
  // request has arrived since they were accepted, so that the ones only waiting to be answered (a 503 for an
  // event stream past its limit, a page) no longer count. Closing is left to the next round of run(), whose
  // poll set still indexes the connections as they are.
  void catch_up(const std::string& address) {
    const auto now = Clock::now();
    for (Connection& c : connections) {
      if (c.address != address || !c.counted_address) continue;
      if (advance(c, POLLIN, now)) {
        release_address(c);
        c.phase = Connection::Phase::kDraining;
        c.drain_until = now;  // dropped in the next round
      }
    }
  }

  // One step of a connection: reads what arrived, answers, writes what the socket takes, drains. True when it
  // is to be closed.
  bool advance(Connection& c, short revents, Clock::time_point now) {
    bool drop = (revents & (POLLERR | POLLNVAL)) != 0;
    if (!drop && c.phase == Connection::Phase::kReading) {
      if (revents & (POLLIN | POLLHUP)) read_request(c);
      if (c.phase == Connection::Phase::kReading && now - c.opened > limits.head_deadline) {
        finish_with(c, plain(408, fmt::format("408 the request head did not arrive within {} ms",
                                               limits.head_deadline.count())));
      }
    }
    if (!drop && c.phase == Connection::Phase::kStreaming && (revents & (POLLIN | POLLHUP))) {
      char sink[512];
      const ssize_t n = ::recv(c.fd, sink, sizeof(sink), 0);
      drop = n == 0 || (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR);
    }
    if (!drop && c.pending()) drop = !write_some(c);
    if (!drop && c.pending() && now - c.last_progress > limits.stuck_write_deadline) drop = true;
    if (!drop && c.phase == Connection::Phase::kWriting && !c.pending()) {
      // Answered: no more to send. Read what the client still sends (a request body never read) until it
      // closes, briefly, so that closing does not reset the connection before it read the answer.
      ::shutdown(c.fd, SHUT_WR);
      c.phase = Connection::Phase::kDraining;
      c.drain_until = now + std::chrono::milliseconds(1000);
      release_address(c);  // answered: its address's next request must not wait for this one to close
    }
    if (!drop && c.phase == Connection::Phase::kDraining) {
      char sink[4096];
      ssize_t n = 0;
      while ((n = ::recv(c.fd, sink, sizeof(sink), 0)) > 0) {
      }
      drop = n == 0 || (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR) || now >= c.drain_until;
    }
    return drop;
  }

  void run() {
    std::vector<pollfd> fds;
    while (!stopping.load()) {
      const auto [version, json] = feed.latest_shared();
      const bool closing = feed.closed();
      for (auto& c : connections) {
        if (c.phase == Connection::Phase::kStreaming) feed_stream(c, version, json, closing);
      }
      fds.clear();
      fds.push_back({listener, POLLIN, 0});
      for (const auto& c : connections) {
        short events = 0;
        if (c.phase == Connection::Phase::kReading || c.phase == Connection::Phase::kDraining) events |= POLLIN;
        if (c.pending()) events |= POLLOUT;
        if (c.phase == Connection::Phase::kStreaming) events |= POLLIN;  // to see the client close
        fds.push_back({c.fd, events, 0});
      }
      (void)::poll(fds.data(), fds.size(), 50);  // 50 ms: a new snapshot reaches the streams within it
      const std::size_t known = connections.size();  // the ones polled (accept_all adds more at the end)
      if (fds[0].revents & POLLIN) accept_all();
      const auto now = Clock::now();
      for (std::size_t i = known; i-- > 0;) {
        if (advance(connections[i], fds[i + 1].revents, now)) close_connection(i);
      }
    }
    while (!connections.empty()) close_connection(connections.size() - 1);
  }
};

DashboardServer::DashboardServer(const SnapshotFeed& feed, std::string chartjs, ServerLimits limits)
    : impl_(std::make_unique<Impl>(feed, std::move(chartjs), limits)) {}

DashboardServer::~DashboardServer() = default;

int DashboardServer::bind(const std::string& address, int port) {
  if (port < 0 || port > 65535) throw InputError(fmt::format("--port {}: must be 0..65535 (0: any free port)", port));
  const std::string a = numeric(address);
  const std::optional<int> family = family_of(a);
  if (!family) {
    throw InputError(fmt::format("--bind '{}': not an IPv4 or IPv6 address (e.g. 127.0.0.1, ::1, 0.0.0.0)", address));
  }
  const int fd = ::socket(*family, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd < 0) throw bind_error(a, port);
  // SO_REUSEADDR (a restart binds at once), never SO_REUSEPORT: with it a second dashboard on the same port
  // would bind too and the kernel would share the connections between the two.
  int yes = 1;
  ::setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof(yes));
  sockaddr_storage storage{};
  socklen_t length = 0;
  if (*family == AF_INET) {
    auto* s4 = reinterpret_cast<sockaddr_in*>(&storage);
    s4->sin_family = AF_INET;
    s4->sin_port = htons(static_cast<std::uint16_t>(port));
    inet_pton(AF_INET, a.c_str(), &s4->sin_addr);
    length = sizeof(sockaddr_in);
  } else {
    auto* s6 = reinterpret_cast<sockaddr_in6*>(&storage);
    s6->sin6_family = AF_INET6;
    s6->sin6_port = htons(static_cast<std::uint16_t>(port));
    inet_pton(AF_INET6, a.c_str(), &s6->sin6_addr);
    length = sizeof(sockaddr_in6);
  }
  if (::bind(fd, reinterpret_cast<sockaddr*>(&storage), length) != 0 || ::listen(fd, 1024) != 0) {
    ::close(fd);
    throw bind_error(a, port);
  }
  if (getsockname(fd, reinterpret_cast<sockaddr*>(&storage), &length) != 0) {
    ::close(fd);
    throw bind_error(a, port);
  }
  if (impl_->listener >= 0) ::close(impl_->listener);
  impl_->listener = fd;
  return ntohs(*family == AF_INET ? reinterpret_cast<sockaddr_in*>(&storage)->sin_port
                                  : reinterpret_cast<sockaddr_in6*>(&storage)->sin6_port);
}

void DashboardServer::serve() {
  if (impl_->listener < 0) throw std::logic_error("DashboardServer::serve before bind");
  impl_->run();
}

void DashboardServer::stop() { impl_->stopping.store(true); }

}  // namespace cpgmatch::cli::dashboard
