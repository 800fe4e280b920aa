#pragma once

// The settings of an MI registration by name, for `register-mi --set NAME=VALUE`: the
// search's and the acceptance checks' internals (pyramid, simplex, restarts, halves, point
// samples, covariance calibration, histogram, footprint) with their ranges.
// RegistrationOptions::Check() checks a whole struct against these ranges.

#include "mmba/core/settings_table.h"
#include "mmba/registration/mi/mi_registration.h"

namespace mmba::registration::mi {

/// Every setting of RegistrationOptions that --set reaches; the names are register-mi's
/// option names without "--" and with '_' for '-' where an option exists (bins, bound_m,
/// halves, …), else the field's name.
const SettingsTable<RegistrationOptions>& RegistrationSettingsTable();

}  // namespace mmba::registration::mi
