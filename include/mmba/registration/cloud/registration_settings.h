#pragma once

#include <string>
#include <vector>

#include "mmba/core/settings_table.h"
#include "mmba/registration/cloud/feature_registration.h"

namespace mmba::registration {

/// The tunable numbers and switches of CloudRegistrationOptions by name, for `register-cloud
/// --set NAME=VALUE`: each one's name, the range it accepts, what it does and its default.
const SettingsTable<CloudRegistrationOptions>& CloudRegistrationSettingsTable();

/// One setting as help lists it.
using RegistrationSetting = SettingInfo;

/// Every setting, in the order of CloudRegistrationOptions.
std::vector<RegistrationSetting> RegistrationSettings();

/// Sets `name` to `value` (a number, an integer or true/false — also 1/0 — as the setting is). Returns
/// false with `problem` ("unknown setting 'x' (closest: …)", "NAME: found 'x', expected a number > 0",
/// …) when the name is unknown or the value is not of its kind or outside its range; `options` is then
/// unchanged.
bool SetRegistrationSetting(const std::string& name, const std::string& value,
                            CloudRegistrationOptions* options, std::string* problem);

/// SetRegistrationSetting for each "NAME=VALUE" of `settings`, in order (`--set`). Returns
/// false at the first one that is malformed or refused, with `problem` naming it.
bool ApplyRegistrationSettings(const std::vector<std::string>& settings,
                               CloudRegistrationOptions* options, std::string* problem);

}  // namespace mmba::registration
