/* A ROS 2 subscriber without ROS 2: what rmw_cyclonedds does for `ros2 topic echo /cpgmatch/study_state`.
 * Cyclone DDS (C API), with types that Cyclone's idlc generated from the IDL that idl/ros2/msg_to_dds_idl.py
 * made of the cpgmatch_msgs .msg files, on the topics ROS 2 maps /cpgmatch/... to (rt/cpgmatch/...), with the
 * QoS `ros2 topic echo` picks for a reliable, transient-local publisher.
 *   ros2_state_reader DOMAIN STUDY_ID MIN_COMPLETED TIMEOUT_S
 * Waits for a state of STUDY_ID with at least MIN_COMPLETED completed rollouts, for one of its trials and for a
 * worker, then prints
 *   state study ID status S completed C budget B name N type T
 *   trial study ID trial I outcome O cost X type T
 *   worker ID kind K slots S alive A type T
 * where T is the type name the matched writer announced; exits 0. Exits 1 on timeout. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "dds/dds.h"
#include "cpgmatch_ros2_msgs.h"

/* The type name of the first writer matched by `reader`, as discovery announced it ("" when none). */
static void matched_type(dds_entity_t reader, char* out, size_t size) {
  dds_instance_handle_t handles[4];
  out[0] = '\0';
  const dds_return_t n = dds_get_matched_publications(reader, handles, 4);
  if (n <= 0) return;
  dds_builtintopic_endpoint_t* writer = dds_get_matched_publication_data(reader, handles[0]);
  if (writer == NULL) return;
  snprintf(out, size, "%s", writer->type_name);
  dds_builtintopic_free_endpoint(writer);
}

static dds_entity_t ros2_reader(dds_entity_t participant, const dds_topic_descriptor_t* type, const char* name,
                                dds_durability_kind_t durability) {
  const dds_entity_t topic = dds_create_topic(participant, type, name, NULL, NULL);
  if (topic < 0) return topic;
  dds_qos_t* qos = dds_create_qos();
  dds_qset_reliability(qos, DDS_RELIABILITY_RELIABLE, DDS_SECS(1));
  dds_qset_durability(qos, durability);
  dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, 100);
  const dds_entity_t reader = dds_create_reader(participant, topic, qos, NULL);
  dds_delete_qos(qos);
  return reader;
}

int main(int argc, char** argv) {
  if (argc != 5) {
    fprintf(stderr, "usage: ros2_state_reader DOMAIN STUDY_ID MIN_COMPLETED TIMEOUT_S\n");
    return 2;
  }
  const dds_domainid_t domain = (dds_domainid_t)atoi(argv[1]);
  const uint32_t study = (uint32_t)atoi(argv[2]);
  const uint32_t min_completed = (uint32_t)atoi(argv[3]);
  const int timeout_s = atoi(argv[4]);
  const dds_entity_t participant = dds_create_participant(domain, NULL, NULL);
  if (participant < 0) {
    fprintf(stderr, "dds_create_participant: %s\n", dds_strretcode(-participant));
    return 1;
  }
  const dds_entity_t states = ros2_reader(participant, &cpgmatch_msgs_msg_dds__StudyState__desc,
                                          "rt/cpgmatch/study_state", DDS_DURABILITY_TRANSIENT_LOCAL);
  const dds_entity_t trials = ros2_reader(participant, &cpgmatch_msgs_msg_dds__TrialRecord__desc,
                                          "rt/cpgmatch/trials", DDS_DURABILITY_TRANSIENT_LOCAL);
  /* Workers are volatile (republished at each heartbeat): a transient-local reader would not match. */
  const dds_entity_t workers = ros2_reader(participant, &cpgmatch_msgs_msg_dds__Worker__desc, "rt/cpgmatch/workers",
                                           DDS_DURABILITY_VOLATILE);
  if (states < 0 || trials < 0 || workers < 0) {
    fprintf(stderr, "cannot create the readers\n");
    return 1;
  }
  char state_line[512] = "", trial_line[256] = "", worker_line[256] = "", type[256];
  void* samples[16] = {NULL};
  dds_sample_info_t infos[16];
  for (int tick = 0; tick < timeout_s * 10 && (state_line[0] == '\0' || trial_line[0] == '\0' || worker_line[0] == '\0');
       ++tick) {
    int n = dds_take(states, samples, infos, 16, 16);
    for (int i = 0; i < n; ++i) {
      const cpgmatch_msgs_msg_dds__StudyState_* s = (const cpgmatch_msgs_msg_dds__StudyState_*)samples[i];
      if (infos[i].valid_data && s->study_id_ == study && s->completed_ >= min_completed && state_line[0] == '\0') {
        matched_type(states, type, sizeof type);
        snprintf(state_line, sizeof state_line, "state study %u status %u completed %u budget %u name %s type %s",
                 s->study_id_, (unsigned)s->status_, s->completed_, s->budget_, s->name_, type);
      }
    }
    if (n > 0) dds_return_loan(states, samples, n);
    n = dds_take(trials, samples, infos, 16, 16);
    for (int i = 0; i < n; ++i) {
      const cpgmatch_msgs_msg_dds__TrialRecord_* t = (const cpgmatch_msgs_msg_dds__TrialRecord_*)samples[i];
      if (infos[i].valid_data && t->study_id_ == study && trial_line[0] == '\0') {
        matched_type(trials, type, sizeof type);
        snprintf(trial_line, sizeof trial_line, "trial study %u trial %u outcome %u cost %.6g type %s", t->study_id_,
                 t->trial_id_, (unsigned)t->outcome_, t->cost_, type);
      }
    }
    if (n > 0) dds_return_loan(trials, samples, n);
    n = dds_take(workers, samples, infos, 16, 16);
    for (int i = 0; i < n; ++i) {
      const cpgmatch_msgs_msg_dds__Worker_* w = (const cpgmatch_msgs_msg_dds__Worker_*)samples[i];
      if (infos[i].valid_data && worker_line[0] == '\0') {
        matched_type(workers, type, sizeof type);
        snprintf(worker_line, sizeof worker_line, "worker %s kind %u slots %u alive %d type %s", w->worker_id_,
                 (unsigned)w->kind_, w->slots_, (int)w->alive_, type);
      }
    }
    if (n > 0) dds_return_loan(workers, samples, n);
    dds_sleepfor(DDS_MSECS(100));
  }
  dds_delete(participant);
  if (state_line[0] == '\0' || trial_line[0] == '\0' || worker_line[0] == '\0') {
    fprintf(stderr, "within %d s: %s / %s / %s\n", timeout_s, state_line[0] ? state_line : "no state of the study",
            trial_line[0] ? trial_line : "no trial of the study", worker_line[0] ? worker_line : "no worker");
    return 1;
  }
  printf("%s\n%s\n%s\n", state_line, trial_line, worker_line);
  return 0;
}
