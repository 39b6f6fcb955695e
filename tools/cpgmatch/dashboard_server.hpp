// The dashboard's HTTP side: the page (compiled in, web_assets.hpp), Chart.js from Debian, the latest snapshot
// as JSON and its changes as server-sent events. Read-only: GET and HEAD, nothing else.
//
// One thread serves every connection (poll over non-blocking sockets), so no client holds a thread: with
// cpp-httplib's thread per connection, 16 slow sockets or 16 open event streams (16 tabs) locked everyone out
// (issue 34). Limits, each answered in plain words:
//   - a request's head must arrive whole within 5 s and within 8 KiB (else 408 / 431), and a request line
//     that is not HTTP gets its 400 as soon as it is read;
//   - at most 1000 connections (a file descriptor each), at most 512 of them and 64 event streams per client
//     address; past a limit the new connection gets a 503 saying which limit (200 slow sockets and 500 tabs
//     from one address leave room for that address's next request);
//   - an event stream gets the newest snapshot whenever it has sent the previous one (a slow reader skips
//     versions, it never queues them) and is dropped when a write is stuck for 30 s.
// Memory is bounded by the limits: per connection at most its 8 KiB request head and a small response (the
// snapshot and Chart.js are shared, not copied), so at most about 1000 x 10 KiB + the snapshots still being
// sent (one per connection at the very worst, usually one or two in all).
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <utility>

namespace cpgmatch::cli::dashboard {

// The newest snapshot text, published by one thread and awaited by every open event stream.
class SnapshotFeed {
 public:
  struct Snapshot {
    std::uint64_t version = 0;  // 0: nothing published yet
    std::string json;
  };
  // A new version only when the text differs: an unchanged domain sends nothing to the browsers.
  void publish(std::string json_text);
  Snapshot latest() const;
  // The first snapshot newer than `seen`, or nullopt after `timeout` or once closed.
  std::optional<Snapshot> wait_newer(std::uint64_t seen, std::chrono::milliseconds timeout) const;
  void close();  // wakes every waiter; the streams end
  bool closed() const;
  // The newest version and its text, shared (not copied: the server hands one text to every stream).
  std::pair<std::uint64_t, std::shared_ptr<const std::string>> latest_shared() const;

 private:
  mutable std::mutex mutex_;
  mutable std::condition_variable changed_;
  Snapshot latest_;
  std::shared_ptr<const std::string> shared_;
  bool closed_ = false;
};

// The server's limits (see the top of this file); a test may lower them.
struct ServerLimits {
  std::size_t max_connections = 1000;
  std::size_t max_connections_per_address = 512;
  std::size_t max_streams_per_address = 64;
  std::size_t max_request_head_bytes = 8192;
  std::chrono::milliseconds head_deadline{5000};
  std::chrono::milliseconds stuck_write_deadline{30000};
  std::chrono::milliseconds keep_alive{15000};  // an idle event stream sends a comment this often
};

// True for 127.0.0.0/8, ::1 and "localhost": the addresses only this machine reaches.
bool is_loopback(const std::string& address);

class DashboardServer {
 public:
  // chartjs: the text of Chart.js (Debian's libjs-chart.js), served as /chart.js.
  DashboardServer(const SnapshotFeed& feed, std::string chartjs, ServerLimits limits = {});
  ~DashboardServer();
  DashboardServer(const DashboardServer&) = delete;
  DashboardServer& operator=(const DashboardServer&) = delete;

  // Binds the listening socket; returns the port (the one the system chose for port 0). A bad address, a port
  // out of range, in use or not allowed is an InputError naming --bind or --port.
  int bind(const std::string& address, int port);
  void serve();  // answers requests until stop()
  void stop();    // from any thread; serve() returns within 50 ms

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace cpgmatch::cli::dashboard
