// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Registration of the verbs; each sets *rc when it runs.
namespace CLI {
class App;
}

namespace adit::tools {

/// `adit map info|convert|query|slice`.
void registerMapVerbs(CLI::App& app, int* rc);
/// `adit plan`.
void registerPlanVerb(CLI::App& app, int* rc);
/// `adit bench global`.
void registerBenchVerb(CLI::App& app, int* rc);

/// `adit simulate SCENARIO.yaml`.
void registerSimulateVerb(CLI::App& app, int* rc);

/// `adit campaign run|merge`.
void registerCampaignVerb(CLI::App& app, int* rc);

/// `adit serve --map M`: the operations console.
void registerServeVerb(CLI::App& app, int* rc);

}  // namespace adit::tools
