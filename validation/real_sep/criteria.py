"""What agreement with physiology means on the real SEPs, fixed before any method ran on them.

Committed in its own commit, before the analysis (``python -m validation.real_sep``) read a
single estimate: the report prints :data:`CRITERIA` first, then each method's numbers
against it. Every rule below uses the sensor data (latencies) and the electrodes' geometry
only, never an estimate.
"""

#: Depth under the scalp of the point the N20 should come from (m): area 3b's hand area lies
#: in the posterior bank of the central sulcus, 20-30 mm under the scalp over C3-CP3.
CENTRAL_DEPTH = 0.025
#: Radius of the central region around that point (m): the spread between subjects of the
#: hand area under the 10-10 electrodes, and the resolution of either source space.
CENTRAL_RADIUS = 0.020
#: A source is deep at most this far from the centre of the sphere fitted to the electrodes
#: (m): thalamus, basal ganglia, insula, cingulate and medial temporal structures lie
#: within it; the cortex of the convexity, the central sulcus included, 55-80 mm out.
DEEP_RADIUS = 0.040
#: The documented N20 latencies (s): "about 24 ms" for A0206 (the data's README), the GFP
#: peak at 19.3 ms for the 256-channel recording (spharapy's examples mark 19 ms).
N20_NEAR = {"A0206": 0.024, "sep256": 0.0193}
#: The P14 is looked for this long before the N20 (s): the P14-N20 interval is 5-6 ms in
#: healthy adults.
P14_BEFORE_N20 = (0.008, 0.004)
#: The direction of the C3-CP3 midpoint from the centre of an ideal spherical 10-10 cap
#: (MNE's ``easycap-M1`` montage, on a sphere about the origin): used where the cap has no
#: 10-10 labels (the 256-channel recording). A0206's own C3 and CP3 give a direction 3
#: degrees from it.
CENTRAL_MONTAGE = "easycap-M1"
#: The 256-channel cap's neck rows (issue 43): the rule, fixed before the run that drops them
#: (:mod:`validation.real_sep.neck` computes it from the electrode positions alone).
NECK_RULE = """\
### The 256-channel cap's neck rows, written before the run that drops them

An outside rerun found that on the 256-channel recording no method puts the N20 in the left
central region, on the sphere or on MNE's sample subject's BEM as a template: the largest
potentials sit on the cap's lowest posterior rows, over the neck (the cervical N13 and the
P14's far field), which a model of the head alone cannot explain. The rule, fixed from the
electrode positions before the run that applies it looked at an estimate:

- **Which electrodes.** The cap has no fiducials. MNE's 10-05 template head (`colin27_1005`:
  343 positions on the Colin27 scalp, with its nasion, preauricular points and inion `Iz`) is
  registered to the cap's triangulated surface (spharapy's 482 triangles, sampled about 3 mm
  apart) by one scale and a translation, the cap's axes kept as the criteria keep them
  (iterated closest points, 100 steps, from the two least-squares spheres; template
  positions farther than 10 mm from the surface left out at each step: the face and the
  lowest template rows, which the cap does not cover). The *neck rows* are the electrodes
  below the plane through the registered inion and the two preauricular points. It gives
  scale 0.935, 331 of the 343 template positions within 10 mm of the cap (RMS 4.2 mm), the
  preauricular points 17 mm and the inion 34 mm above the cap's origin (the plane rises
  towards the back), and 35 electrodes below the plane: Z18L, Z19L, L1Z, L2Z, L10Z, L13Z,
  L1L, L11L, L2A, L5B, L6B, L8C, L8D, L5E, L4H, L5H, Z1Z, Z2Z, Z10Z, Z3R, Z11R, R2Z, R12Z,
  R1R, R2R, R11R, R19R, R6A, R7E, R8E, R9E, R10E, R1F, R2F, R6F. 29 of them lie behind the
  preauricular points (the neck and the mastoids), 6 in front of them (L10Z, L1L, L11L,
  Z10Z, Z11R, R2Z: over the jaw, below the head as well). The plane is known to a few mm:
  trimming at 5 to 15 mm instead of 10 moves up to 4 electrodes at it across (L7D, L9Z, R4E,
  R5E), and a fit that may also turn (it turns 6 degrees) moves 6 (L9Z and Z9Z in; L5E,
  L5H, R9E, Z19L out; corrected after this rule was committed, which said 5 degrees and 5
  electrodes, from a draft of the registration; the 35 rows are the same). The rule is kept
  as written.
- **Dropped, not modelled.** Modelling them needs a conductor that holds the neck and
  sources in the brainstem and the cervical cord: no MRI comes with the recording, and a
  sphere cannot. They are dropped: the simplest choice, and it hides nothing (the
  all-channel run is reported beside it).
- **Nothing else changes.** The recording without them (`sep256-head`, 221 channels) is the
  same average re-referenced to the average of its channels, its noise covariance from the
  same baseline (-50 ... 0 ms, 10 % regularized); the forward is the all-channel one with
  those rows removed (the sphere and its 10 mm grid fitted to all 256 electrodes: the grid
  still fills the sphere below the plane); the criteria's geometry (the centre, `p*`) and the
  latencies are the all-channel recording's. Every setting runs on both.
- **The question.** Does any setting now put the N20 maximum in the left central region
  (contralateral to the right median nerve: left hemisphere, under C3/CP3), that is, meet
  the three N20 checks on `sep256-head`? Reported whatever the answer.
"""
#: The criteria, in the report's words.
CRITERIA = """\
### The criteria, written before the numbers

**What physiology says** (not these recordings): after stimulation of the right median
nerve, the N20 is generated in the contralateral (left) primary somatosensory cortex, area
3b, on the posterior wall of the central sulcus in the hand area, by a mostly tangential
dipole (hence the negativity over the parietal and the positivity over the frontal scalp).
The P14 is subcortical (medial lemniscus, from the brainstem to the thalamus); the P16/P18
are deep (thalamic and subcortical). A method agrees with physiology where its maxima say
the same.

**Geometry** (MNE's head-frame axes, x to the right, y to the front, z up, in metres; from
the electrodes only):

- *the head's centre* `c` and radius: the sphere MNE fits to the recording's electrodes
  (`mne.bem.fit_sphere_to_headshape(info, dig_kinds=("eeg",))`);
- *left hemisphere*: x < x of `c`;
- *the central region under C3/CP3*: the positions within 20 mm of the point `p*` 25 mm
  under the scalp below the midpoint of C3 and CP3: `p* = c + (|m - c| - 25 mm) u`,
  `u = (m - c) / |m - c|`, `m` that midpoint (A0206: its own electrodes; the 256-channel cap,
  which has no 10-10 labels: `u` the direction of the C3-CP3 midpoint on MNE's ideal
  spherical `easycap-M1` cap and `|m - c|` the fitted radius). The distance to the region is
  `max(0, |r - p*| - 20 mm)`;
- *deep*: at most 40 mm from `c`.

**Latencies** (from the global field power, GFP, of the sensor data only): *N20* the GFP
peak nearest the documented latency (A0206 24 ms, 256 channels 19.3 ms); *P14* the largest
GFP peak from 8 to 4 ms before the N20; *P16* halfway between the P14 and the N20.

**Amplitude and maximum**: at each position the estimate's absolute value (fixed
orientation) or norm over its three orientations (free), at one sample; the maximum is the
position of the largest amplitude. Units differ between methods (A m, F, z values):
positions are compared, never amplitudes.

**Agreement, per method and recording** (five checks):

1. N20 left: the maximum at the N20 is in the left hemisphere;
2. N20 central: it is in the central region under C3/CP3;
3. N20 cortical: it is not deep;
4. P14 deep: the maximum at the P14 is deep;
5. P16 deep: the maximum at the P16 is deep.

For A0206 the axis of the source at the N20 maximum is reported (each FEM position has one
Cartesian axis; area 3b's dipole is tangential: at more than 60 degrees from `u`), not
scored. The time courses shown are those of the N20 maximum, of the largest deep source at
the P14, and of the largest amplitude in the central and the deep regions.

**What is compared**: the SKF at the paper's setting and at the recommended one (each
column standardized on its own, as the paper does), each with
priors chosen by the data (the marginal likelihood, PM-SNR and EP-SNR in -20 ... 40 dB) and
at fixed priors (PM 0 / EP 20 dB, the paper's for its smoother; PM 0 / EP 0 dB); MNE's
MNE, dSPM, sLORETA and eLORETA with lambda2 by the discrepancy principle (the whitened
residual of the minimum-norm estimate over the post-stimulus samples equals its expected
value, the noise rank times the number of samples; the same lambda2 for the four) and at
lambda2 = 1/9; LCMV (MNE's defaults: reg 0.05, unit-noise-gain; data covariance of the
average from 0 ms on); MxNE with alpha by SURE (data-driven) and at 50 % of alpha_max. The
minimum-norm methods run without depth weighting (MNE refuses it on a forward that was
never free, as A0206's FEM; the same on the sphere), MxNE at MNE's default depth (0.8).
Noise covariance: the average's baseline (A0206 -100 ... -20 ms, 256 channels -50 ... 0
ms), 10 % regularized, in MNE's convention with `nave`; the methods that ignore `nave`
(LCMV, MxNE; the SKF too until 0.4.0) get the covariance of the average itself.

*Added after the first run* (no contrast named for them, reported beside the others): the
SKF standardizing each source position's columns together (`standardize="position"`,
exponent 0.5, no smoother; with PM 0 / EP 0 dB the package's default since the simulated
study chose it) and the same with the smoother standardized by its own variance
(`"rts-smoothed-weights"`), at the same three priors.

*Added in the third run* (issue 43; no contrast named for them either): the candidates an
evidence study is choosing the package's default among, exponent 0.5, each column or each
position standardized, without a smoother or with `"rts-smoothed-weights"` (the column form
with it is new, and also gets the walk's three priors), each with the random walk at PM 0 /
EP 0 dB (the default) and PM 0 / EP 20 dB (the paper's), and with the stationary AR(1)
evolution prior (`time_constant_ms=`, skf_ref 0.4.0) at PM 0 dB: time constants 10, 30 and
100 ms, and the time constant chosen by the marginal likelihood in 1 ... 1000 ms with the
PM-SNR kept at 0 dB (as `apply_skf(..., time_constant_ms="auto")` does; counted among the
priors chosen by the data). In the tables "recommended" is the column form without a
smoother, "position" the position form without one.

**Contrasts named before the numbers**: (a) the SKF at the recommended setting against the
paper's; (b) the SKF at the recommended setting (priors chosen by the data) against the
best of MNE's methods with lambda2 by the discrepancy principle, by the number of checks
met and then by the N20 maximum's distance to the central region. Two recordings (one
with its own head model), one estimate each: no statistics, no claim beyond them.

### What cannot be known here

- **The truth.** No recording comes with its generators: agreement with physiology is the
  only reference, and the physiology is of populations, not of these subjects.
- **The FEM is the source's.** A0206's lead field, its source space and its conductivities
  were computed by the feCNN authors (duneuro); they cannot be varied or checked here, and
  every method inherits their errors alike.
- **One orientation per position** in A0206's FEM source space (5046 positions, each with
  one Cartesian axis): no position can hold the N20's tangential dipole at its own
  orientation; a maximum lands on a neighbour whose axis explains the field, a few mm off.
- **The source space's extent.** The FEM's sources stop 68 mm below the head's centre; whether
  they reach the brainstem, where the P14 begins, is not documented.
- **The sphere is crude.** The 256-channel recording has no MRI: a three-shell sphere fitted
  to the cap, a 10 mm volume grid inside it, a cap without fiducials (its axes are its own).
- **Three subjects, one head model.** A1974 and A1999 have no lead field: only their sensor
  data are checked (the N20's latency and topography).
- **The P14 and P16 are weak.** They are far fields of small deep generators, at a tenth of
  the N20's power or less; a maximum at their latency may be the N20's onset or noise.
- **The high-pass.** A0206's 20 Hz high-pass (zero-phase) shapes every deflection and
  spreads the stimulus artifact backwards in time; the 256-channel recording is high-passed
  at 2 Hz.
"""
