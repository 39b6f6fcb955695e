// Test helper: sends malformed and oversized rollout trace chunks to the optimizer, the way a buggy or
// hostile participant might, in the middle of a study.
//   inject_trace_chunks DOMAIN STORE_ID STUDY_ID
// Every chunk must be rejected (and counted) by the optimizer, which must neither crash nor store any of
// them. Prints one line per chunk sent; exits 0 once all were written and acknowledged.
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <string>

#include "cpgmatch/dds/convert_trace.hpp"
#include "cpgmatch/dds/participant.hpp"
#include "cpgmatch/params.hpp"

using namespace std::chrono_literals;
namespace transport = cpgmatch::dds;
namespace domain = cpgmatch::domain;
namespace msg = cpgmatch::msg;

int main(int argc, char** argv) {
  if (argc != 4) {
    std::cerr << "usage: inject_trace_chunks DOMAIN STORE_ID STUDY_ID\n";
    return 2;
  }
  const int domain_id = std::atoi(argv[1]);
  const std::uint64_t store = std::stoull(argv[2]);
  const int study = std::atoi(argv[3]);
  transport::Participant p(transport::ParticipantConfig::basic(domain_id, "trace-injector", true));
  transport::Writer<msg::RolloutTraceChunk> writer(p);
  if (!writer.matched().wait_for(1, 10s)) {
    std::cerr << "inject_trace_chunks: no trace reader on domain " << domain_id << "\n";
    return 1;
  }
  // A well-formed one-chunk trace of trial 1 (the attempt the robot runs), then each fault on a copy.
  domain::RolloutTraceChunk good;
  good.id = {store, study, 1, 0};
  good.worker_id = "morti";
  good.chunk_count = 1;
  good.total_ticks = 4;
  good.control_rate_hz = 500.0;
  good.terrain = "flat";
  good.parameters = cpgmatch::to_map(cpgmatch::CpgParameters{});
  for (int i = 0; i < 4; ++i) {
    domain::MeasuredTick t;
    t.legs = cpgmatch::PerLeg<cpgmatch::domain::MeasuredLeg>(4);
    t.time_s = i / 500.0;
    good.ticks.push_back(t);
  }
  auto send = [&](domain::RolloutTraceChunk c, const char* what) {
    writer.write(transport::to_wire(c));
    std::cout << "sent trace chunk: " << what << std::endl;
  };
  domain::RolloutTraceChunk c = good;
  c.total_ticks = 1000000000;  // a billion ticks: more than any trace may hold
  c.chunk_count = 4000000;
  send(c, "oversized (a billion ticks announced)");
  c = good;
  c.ticks[2].legs[1].knee_rad = std::nan("");
  send(c, "a NaN knee angle");
  c = good;
  c.ticks[3].time_s = 1.0;
  send(c, "a tick off the control grid");
  c = good;
  c.chunk_index = 7;
  send(c, "chunk index past its count");
  c = good;
  c.control_rate_hz = -500.0;
  send(c, "a negative control rate");
  c = good;
  c.id.trial_id = 99999;
  send(c, "a trial the study never issued");
  c = good;
  c.id.attempt = 40;
  send(c, "an attempt never issued");
  // The first of three chunks of trial 2's trace, then a second that contradicts it; the trace never
  // completes (the optimizer gives it up after its time limit).
  c = good;
  c.worker_id = "impostor";  // not the robot's id: its real trace of the same trial is not in the way
  c.id.trial_id = 2;
  c.chunk_count = 3;
  c.total_ticks = 12;
  send(c, "chunk 0 of 3 of an incomplete trace");
  c.chunk_index = 1;
  c.first_tick = 4;
  c.seed = 99;
  for (int i = 0; i < 4; ++i) c.ticks[i].time_s = (4 + i) / 500.0;
  send(c, "chunk 1 whose header contradicts chunk 0");
  writer.wait_for_acknowledgments(10s);
  return 0;
}
