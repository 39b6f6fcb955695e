// The four contact-triggered elastic feedback mechanisms of the paper, per leg.
//
// Each leg runs a small state machine over its CPG phase and its binary contact signal:
//
//   late touchdown  (LTD): stance has begun (phi in [0, D)) but the foot has not touched down yet.
//                          The leg's phase is decelerated until contact ("wait for the ground"), for at
//                          most late_touchdown_max_wait_s per stance; measured for as long as it lasts.
//   early touchdown (ETD): the foot touches down during swing, after it had been airborne for at least
//                          etd_min_airborne_s, while the knee is still flexed for ground clearance (more
//                          than etd_min_knee_flexion_fraction of its amplitude, or before the flexion
//                          peak). A contact with the leg re-extended for landing, just before the
//                          overswing point, is the touchdown Fig. 2d expects at delta_overSwing, arriving
//                          a few milliseconds early: stance, not a stumble. Triggers a knee pull-up reflex
//                          on a fixed trajectory and makes the hip motor passive for the impact (the
//                          first reflex_hip_passive_s), so the leg springs absorb it; then the hip drives the
//                          swing on while the knee is still pulled up. The airborne time keeps a toe that
//                          scuffs the ground just after toe-off (which is a late toe-off, not an impact) from
//                          firing the reflex. The reflex acts only while the other leg of the girdle is on
//                          the ground (reflex_needs_girdle_support); otherwise the early touchdown is
//                          measured but the leg is left to carry the girdle.
//   early toe-off   (ETO): the foot is off the ground in the second half of stance (from mid-stance, where
//                          the leg passes under the hip and starts to unload; lost there, or lost earlier and
//                          still not back) before the knee was scheduled to flex. Knee flexion starts at once
//                          instead of waiting for the feedforward schedule. If contact returns before the
//                          scheduled flexion (the foot slipped or bounced, the leg is loaded again) the early
//                          flexion is cancelled: flexing a loaded knee buckles it. A contact lost and regained
//                          within the first half is a bounce: neither acted on nor counted here (J_contact
//                          counts its extra contact changes). With knee_phase_shift >= 0.5 the knee is due to
//                          flex by mid-stance anyway, so there is no early toe-off to act on.
//
// Against the paper's Fig. 2d (one step cycle in phase, stance [0, D) shaded): LTD is the red segment at the
// start of stance, ETO the green one inside stance before the knee phase shift, LTO the yellow one after the
// nominal toe-off, ETD the purple one in swing before the overswing (retraction) begins. Contact is the
// debounced FootTile signal (see contact_sensor.hpp).
//   late toe-off    (LTO): the foot is still on the ground after the nominal toe-off (phi >= D) and has
//                          not lifted since. Always measured; decelerates the phase only if configured.
//
// The activity flags r(t) are what the cost's J_feedback integrates: they are true while a mechanism is
// correcting or its mismatch lasts (LTD: ground missing in stance, held back or not; ETD: reflex running;
// ETO: knee ahead of schedule; LTO: contact held too long). A disabled mechanism is still *measured* only
// for LTO, as the paper does; the others neither act nor report when switched off (for ablations).
#pragma once

#include "cpgmatch/cpg.hpp"

namespace cpgmatch {

struct FeedbackConfig {
  bool late_touchdown = true;
  bool early_touchdown = true;
  bool early_toeoff = true;
  bool late_toeoff_deceleration = false;  // LTO is always measured; this also slows the phase
  double late_touchdown_phase_rate = 0.1;  // phase speed factor while waiting for touchdown (0..1)
  // Longest a leg's phase is held back per stance while it waits for the ground, seconds; LTD is still
  // *measured* for as long as the ground is missing. 10 (the largest the YAML accepts; a stance is far
  // shorter) is the paper's literal "until contact".
  // Why 0.1 s: a body falling onto the waiting leg drops g t^2 / 2 = 5 cm in 0.1 s, so a foot still in
  // the air after that hangs because the other legs carry the body, and holding it longer keeps the hip at
  // its most forward angle, where the foot may never reach the ground, while its diagonal partner walks on
  // (traced in docs/model.md). Measured in docs/model.md, "Feedback on random gaits".
  double late_touchdown_max_wait_s = 0.1;
  double late_toeoff_phase_rate = 0.5;     // phase speed factor during LTO, when deceleration is on
  double reflex_duration_s = 0.12;         // knee pull-up reflex length, seconds
  double etd_min_airborne_s = 0.04;        // swing contact counts as ETD only after this long in the air, s
  // A swing contact is an ETD only while the commanded knee flexion exceeds this fraction of the knee
  // amplitude (or the knee is still flexing). Why 0.2: the leg's length changes by about 0.1 m per radian
  // of knee flexion, so with the paper's 0.52 rad amplitude 20% leaves ~1 cm of clearance; a foot meeting
  // the ground that close to its landing length is landing (at a ~0.3 m/s descent, ~30 ms early), not
  // hitting an obstacle. Without this, a foot landing 5-10 ms before retraction fired the reflex, which
  // lifted it off again: a systematic double contact on most gaits (J_contact ~1, traced in docs/model.md).
  double etd_min_knee_flexion_fraction = 0.2;
  double reflex_knee_flexion_rad = 0.5;    // peak extra knee flexion of the reflex, radians
  // Early toe-off counts only once the stance phase has reached this fraction of the duty factor (0.5:
  // mid-stance, where the hip passes its offset). A toe-off is the foot leaving the ground as the leg
  // unloads behind the hip; a contact lost earlier, with the leg still in front of the hip taking the
  // body's weight, is a bounce or a stumble, and flexing that knee removes the support the body is falling
  // onto (measured: docs/model.md, "Feedback on random gaits"). 0 is the window used before 2026-12-02:
  // the whole stance before the scheduled knee flexion.
  double eto_min_stance_fraction = 0.5;
  // The hip motor is passive ("disabled from interfering in the passive impact mitigation of the mechanical
  // leg springs", paper) for the first reflex_hip_passive_s of the reflex, then drives its swing again.
  // Why 0.04 s: that is the impact, the leg spring's compression under a leg's share of the body,
  // a quarter period pi/2 sqrt(m/k) = pi/2 sqrt(1 kg / 1.5 kN/m) = 41 ms (knee spring 15 N m/rad on the
  // leg's ~0.1 m lever; configs/model/morti.yaml). After it the reflex's job is ground clearance, and a
  // foot lifted over an obstacle must also keep moving forward: in animals the stumbling corrective
  // reaction flexes the knee *and* keeps flexing the hip (Forssberg 1979). A hip left passive for the
  // whole reflex lets the ground drag the leg back, and the leg lands far behind its target.
  // Measured in docs/model.md ("Feedback on perturbed ground"). reflex_duration_s or more: passive for the
  // whole reflex (this project's reading until 2026-12-02); 0, or reflex_hip_passive false: always driven.
  double reflex_hip_passive_s = 0.04;
  bool reflex_hip_passive = true;  // false: the hip keeps driving during the reflex (ablation)
  // The knee pull-up fires only while the other leg of the same girdle (front or hind pair) is on the
  // ground. Why: a girdle is held up by its two legs, and in a trot one of them is in stance. A swing foot
  // meeting the ground while its partner is also off the ground is the girdle falling onto that foot (the
  // partner touches down late, or the lift-off failed), not a foot hitting an obstacle, and pulling that
  // knee up takes away the girdle's only support. Animals do the same with load: a stimulus that flexes a
  // swinging leg extends a loaded one (phase-dependent reflex reversal, Forssberg 1979), and a loaded leg
  // is not lifted (Duysens and Pearson 1980). Contact is all this controller senses, so the partner's
  // contact stands for "the girdle is carried". The early touchdown is still measured for the reflex's
  // duration (the mismatch is there), only its action is withheld. Only where the gait alternates a girdle's
  // legs (trot, pace, walk); in a bound or a pronk CpgController passes the girdle as carried. Measured in
  // docs/model.md ("A reflex that keeps the girdle carried"). false: the reflex fires whatever the partner
  // does (before 2026-12-02).
  bool reflex_needs_girdle_support = true;

  // Everything off: the open-loop CPG (LTO is still measured).
  static FeedbackConfig none();
};

struct FeedbackActivity {
  bool late_touchdown = false;
  bool early_touchdown = false;
  bool early_toeoff = false;
  bool late_toeoff = false;
  int count() const { return late_touchdown + early_touchdown + early_toeoff + late_toeoff; }
};

// What feedback asks of the leg's trajectory generator and oscillator for this control tick.
struct FeedbackAction {
  double phase_rate = 1.0;          // multiplies the oscillator's own frequency (not its coupling)
  double extra_knee_flexion = 0.0;  // rad, added to the feedforward knee target (reflex)
  double knee_flex_start = -1.0;    // phase; >= 0 replaces the scheduled knee flexion start (ETO)
  bool hip_passive = false;
  FeedbackActivity activity;
};

class LegFeedback {
 public:
  LegFeedback() : LegFeedback(FeedbackConfig{}) {}  // not explicit: PerLeg value-initialises its items
  explicit LegFeedback(FeedbackConfig config);

  // Call once per control tick with the leg's phase before and after the previous oscillator step and
  // the latest polled contact. dt_s is the control period.
  // girdle_carried: the other leg of the same girdle (FL-FR, HL-HR) is on the ground this tick, or the gait
  // swings both together (bound, pronk), where the partner says nothing (CpgController decides).
  FeedbackAction update(double phase, bool contact, double dt_s, const StepTiming& timing, bool girdle_carried);

  void reset();

 private:
  enum class Part { kStance, kSwing };

  // In swing, the knee has re-extended for landing (below etd_min_knee_flexion_fraction of its amplitude).
  bool landing_ready(double phase, const StepTiming& timing) const;

  FeedbackConfig config_;
  bool initialised_ = false;
  double last_phase_ = 0.0;
  bool touched_down_ = false;   // contact seen since this stance window began (or in retraction)
  bool lifted_off_ = false;     // contact lost since the nominal toe-off of this swing
  bool was_contact_ = true;
  double airborne_s_ = 0.0;     // time since the foot last left the ground (0 while in contact)
  double last_flight_s_ = 0.0;  // length of the flight that ended with the latest touchdown
  bool reflex_used_ = false;    // one reflex per swing
  double reflex_time_left_ = 0.0;
  bool reflex_withheld_ = false;  // this early touchdown is measured but not acted on (no girdle support)
  double early_flex_start_ = -1.0;  // phase at which ETO started knee flexion, this cycle
  double late_touchdown_wait_s_ = 0.0;  // time the phase has waited for touchdown in this stance window
};

}  // namespace cpgmatch
