// The dashboard's HTTP side (cpp-httplib): the page (compiled in, web_assets.hpp), Chart.js from Debian, the
// latest snapshot as JSON and its changes as server-sent events. Read-only: GET and HEAD, nothing else.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

namespace httplib {
class Server;
}

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

 private:
  mutable std::mutex mutex_;
  mutable std::condition_variable changed_;
  Snapshot latest_;
  bool closed_ = false;
};

// True for 127.0.0.0/8, ::1 and "localhost": the addresses only this machine reaches.
bool is_loopback(const std::string& address);

class DashboardServer {
 public:
  // chartjs: the text of Chart.js (Debian's libjs-chart.js), served as /chart.js.
  DashboardServer(const SnapshotFeed& feed, std::string chartjs);
  ~DashboardServer();
  DashboardServer(const DashboardServer&) = delete;
  DashboardServer& operator=(const DashboardServer&) = delete;

  // Binds the listening socket; returns the port (the one the system chose for port 0). A bad address, a port
  // out of range, in use or not allowed is an InputError naming --bind or --port.
  int bind(const std::string& address, int port);
  void serve();  // answers requests until stop()
  void stop();

 private:
  const SnapshotFeed& feed_;
  std::string chartjs_;
  std::unique_ptr<httplib::Server> server_;
};

}  // namespace cpgmatch::cli::dashboard
