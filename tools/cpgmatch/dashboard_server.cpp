#include "dashboard_server.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>

#include <fmt/format.h>
#include <httplib.h>

#include "cpgmatch/errors.hpp"
#include "web_assets.hpp"

namespace cpgmatch::cli::dashboard {

namespace {

// A browser tab keeps one event stream (and so one of the server's threads) open: room for a dozen tabs
// beside the page's own requests. httplib's default is max(8, cores - 1).
constexpr std::size_t kHttpThreads = 16;
// An idle stream still sends a comment this often, so that a proxy or the browser does not drop it.
constexpr std::chrono::seconds kKeepAlive{15};

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

void serve_text(httplib::Response& res, const std::string& body, const char* content_type) {
  res.set_content(body, content_type);
}

}  // namespace

void SnapshotFeed::publish(std::string json_text) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (latest_.version > 0 && latest_.json == json_text) return;
    latest_.json = std::move(json_text);
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

bool is_loopback(const std::string& address) {
  const std::string a = numeric(address);
  in_addr v4{};
  if (inet_pton(AF_INET, a.c_str(), &v4) == 1) return (ntohl(v4.s_addr) >> 24) == 127;
  in6_addr v6{};
  return inet_pton(AF_INET6, a.c_str(), &v6) == 1 && IN6_IS_ADDR_LOOPBACK(&v6);
}

DashboardServer::DashboardServer(const SnapshotFeed& feed, std::string chartjs)
    : feed_(feed), chartjs_(std::move(chartjs)), server_(std::make_unique<httplib::Server>()) {
  httplib::Server& s = *server_;
  s.new_task_queue = [] { return new httplib::ThreadPool(kHttpThreads); };
  // httplib sets SO_REUSEPORT, with which a second dashboard on the same port would bind too and the kernel
  // would share the connections between the two. SO_REUSEADDR alone still allows a restart right away.
  s.set_socket_options([](socket_t sock) {
    int yes = 1;
    ::setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof(yes));
  });
  // Study data only (served unauthenticated): no caching, nothing but this server's own files and data:
  // images, and no sniffing a type.
  s.set_default_headers({{"Cache-Control", "no-store"},
                         {"X-Content-Type-Options", "nosniff"},
                         {"Content-Security-Policy",
                          "default-src 'self'; img-src 'self' data:; style-src 'self'; script-src 'self'; "
                          "connect-src 'self'; frame-ancestors 'none'"}});
  // Read-only: anything but GET and HEAD is refused before routing, whatever the path.
  s.set_pre_routing_handler([](const httplib::Request& req, httplib::Response& res) {
    if (req.method == "GET" || req.method == "HEAD") return httplib::Server::HandlerResponse::Unhandled;
    res.status = 405;
    res.set_header("Allow", "GET, HEAD");
    res.set_content("read-only: GET and HEAD only\n", "text/plain");
    return httplib::Server::HandlerResponse::Handled;
  });
  for (const web::Asset& asset : web::dashboard_assets()) {
    const std::string body(asset.body);
    const std::string type(asset.content_type);
    s.Get(std::string(asset.path), [body, type](const httplib::Request&, httplib::Response& res) {
      serve_text(res, body, type.c_str());
    });
  }
  s.Get("/chart.js", [this](const httplib::Request&, httplib::Response& res) {
    serve_text(res, chartjs_, "text/javascript");
  });
  s.Get("/api/snapshot", [this](const httplib::Request&, httplib::Response& res) {
    serve_text(res, feed_.latest().json, "application/json");
  });
  s.Get("/events", [this](const httplib::Request&, httplib::Response& res) {
    // Every change of the snapshot, whole (the page redraws from it); the first one at once.
    auto seen = std::make_shared<std::uint64_t>(0);
    res.set_chunked_content_provider("text/event-stream", [this, seen](std::size_t, httplib::DataSink& sink) {
      const auto next = feed_.wait_newer(*seen, kKeepAlive);
      if (feed_.closed()) {
        sink.done();
        return true;
      }
      std::string chunk = ": keep-alive\n\n";
      if (next) {
        // A JSON dump has no raw newline, so the whole snapshot is one data line.
        chunk = fmt::format("{}event: snapshot\ndata: {}\n\n", *seen == 0 ? "retry: 2000\n" : "", next->json);
        *seen = next->version;
      }
      return sink.write(chunk.data(), chunk.size());
    });
  });
}

DashboardServer::~DashboardServer() = default;

int DashboardServer::bind(const std::string& address, int port) {
  if (port < 0 || port > 65535) throw InputError(fmt::format("--port {}: must be 0..65535 (0: any free port)", port));
  const std::string a = numeric(address);
  if (!family_of(a)) {
    throw InputError(fmt::format("--bind '{}': not an IPv4 or IPv6 address (e.g. 127.0.0.1, ::1, 0.0.0.0)", address));
  }
  if (port == 0) {
    const int bound = server_->bind_to_any_port(a);
    if (bound < 0) throw bind_error(a, 0);
    return bound;
  }
  if (!server_->bind_to_port(a, port)) throw bind_error(a, port);
  return port;
}

void DashboardServer::serve() { server_->listen_after_bind(); }

void DashboardServer::stop() { server_->stop(); }

}  // namespace cpgmatch::cli::dashboard
