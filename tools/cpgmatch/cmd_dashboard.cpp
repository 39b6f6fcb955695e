// `cpgmatch dashboard [--port 8080] [--bind 127.0.0.1] [--domain D]`: a DDS client (the viewer enclave under
// DDS-Security) that serves a live web page of every study on the domain. Read-only, offline (Chart.js from
// Debian, the page compiled in); loopback only unless --bind says otherwise, out loud, because it serves
// study data without authentication. docs/dashboard.md.
#include <csignal>
#include <fstream>
#include <iostream>
#include <sstream>
#include <optional>
#include <thread>

#include <fmt/format.h>

#include "commands.hpp"
#include "dashboard_server.hpp"
#include "dashboard_snapshot.hpp"
#include "service_flags.hpp"
#include "study_client.hpp"

namespace cpgmatch::cli {

namespace {

// Debian's libjs-chart.js (3.9): the UMD build, which defines the global `Chart` the page uses.
constexpr const char* kDebianChartJs = "/usr/share/javascript/chart.js/chart.min.js";
// The page is redrawn from a new snapshot at most this often (the optimizer publishes a state every 0.1 s).
constexpr std::chrono::milliseconds kRefresh{250};

volatile std::sig_atomic_t g_stop = 0;

std::string read_chartjs(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    throw InputError(fmt::format("--chartjs {}: no such file (install Debian's libjs-chart.js, or give its path)", path));
  }
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

dashboard::DomainView view_of(const client::StudyClient& c, int domain, bool optimizer_heard) {
  dashboard::DomainView v;
  v.domain = domain;
  v.optimizer_heard = optimizer_heard;
  v.states = c.states();
  v.workers = c.workers();
  for (const auto& [id, state] : v.states) v.trials[id] = c.trials(id);
  return v;
}

}  // namespace

void add_dashboard_command(CLI::App& app) {
  struct Options {
    ServiceFlags service;
    int port = 8080;
    std::string bind = "127.0.0.1";
    std::string chartjs = kDebianChartJs;
  };
  auto o = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand(
      "dashboard", "serve a live, read-only web page of every study on the DDS domain (Ctrl-C to stop)");
  cmd->add_option("--port", o->port, "TCP port (0: any free one; the URL is printed)")->capture_default_str();
  cmd->add_option("--bind", o->bind,
                  "address to listen on; anything but the loopback serves study data to the network, unauthenticated")
      ->capture_default_str();
  cmd->add_option("--chartjs", o->chartjs, "Chart.js (UMD build) to serve to the page")->capture_default_str();
  cmd->add_option("--domain", o->service.domain, "DDS domain id (default: $CPGMATCH_DOMAIN, else 0)");
  cmd->add_flag("--localhost-only", o->service.localhost_only, "DDS over 127.0.0.1 only (a private study on one machine)");
  runtime::add_dds_flags(*cmd, o->service.dds, "viewer");
  cmd->callback([o] {
    const int domain = o->service.resolved_domain();
    dashboard::SnapshotFeed feed;
    dashboard::DashboardServer server(feed, read_chartjs(o->chartjs));
    // The socket first: a port in use or a bad address is said at once, before DDS discovery starts.
    const int port = server.bind(o->bind, o->port);
    if (!dashboard::is_loopback(o->bind)) {
      fmt::print(stderr,
                 "warning: --bind {}: the dashboard is reachable from other machines and serves this domain's study "
                 "data to anyone who connects, without authentication (read-only)\n",
                 o->bind);
    }
    runtime::apply_dds_flags(o->service.dds);
    client::StudyClient client(domain, o->service.localhost_only, /*read_trials=*/true);
    const std::string host = o->bind.find(':') != std::string::npos ? "[" + o->bind + "]" : o->bind;
    fmt::print("cpgmatch dashboard: http://{}:{}/  (DDS domain {}, read-only; Ctrl-C to stop)\n", host, port, domain);
    std::fflush(stdout);

    std::signal(SIGINT, [](int) { g_stop = 1; });
    std::signal(SIGTERM, [](int) { g_stop = 1; });
    std::signal(SIGPIPE, SIG_IGN);  // a browser that closes its tab mid-write must not end the program
    std::thread http([&server] { server.serve(); });
    // A snapshot is built only when the client took in a sample since the last one (or the optimizer came or
    // went): an idle domain costs no JSON work.
    std::optional<std::pair<std::uint64_t, bool>> drawn;
    while (!g_stop) {
      const bool optimizer_heard = client.wait_for_optimizer(0.0, 0.0);
      const std::pair<std::uint64_t, bool> now{client.revision(), optimizer_heard};
      if (drawn != now) {
        feed.publish(dashboard::snapshot_json(view_of(client, domain, optimizer_heard)).dump());
        drawn = now;
      }
      std::this_thread::sleep_for(kRefresh);
    }
    feed.close();  // ends the open event streams, so that stop() can join the server's threads
    server.stop();
    http.join();
  });
}

}  // namespace cpgmatch::cli
