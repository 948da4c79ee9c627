// SPDX-License-Identifier: BSD-3-Clause
// adit: one binary, git-style verbs. Each verb lives in its own file; this one only dispatches.
#include <CLI/CLI.hpp>

#include <cstdio>
#include <exception>

#include "common/cli.hpp"
#include "verbs.hpp"

namespace {

int run(int argc, char** argv) {
  CLI::App app{"adit: path planning for underground mine roadways.\n"
               "Results go to stdout, logs and progress to stderr.\n"
               "Exit codes: 0 success, 1 failure, 2 bad input, 3 no path (plan)."};
  app.set_version_flag("--version", std::string(ADIT_VERSION));
  app.require_subcommand(1);
  int rc = adit::tools::kExitOk;
  adit::tools::registerMapVerbs(app, &rc);
  adit::tools::registerPlanVerb(app, &rc);
  adit::tools::registerBenchVerb(app, &rc);
  adit::tools::registerSimulateVerb(app, &rc);
  adit::tools::registerCampaignVerb(app, &rc);
  adit::tools::registerServeVerb(app, &rc);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);  // prints help or the usage error
    return code == 0 ? adit::tools::kExitOk : adit::tools::kExitBadInput;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "adit: internal error: %s\n", e.what());
    return adit::tools::kExitFailure;
  }
  return rc;
}

}  // namespace

int main(int argc, char** argv) { return adit::tools::finishStdout(run(argc, argv)); }
