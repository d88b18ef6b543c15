// slamctl: the command-line client of slamd. One binary, one file per subcommand.
#include <cstdio>

#include "clients/slamctl/commands.h"
#include "core/base/memory_usage.h"

int main(int argc, char** argv) {
  slamd::core::KeepFreedMemoryForReuse();
  CLI::App app{"slamctl: replay, query, watch, plot, simulate and benchmark slamd"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "slamctl 0.1.0");
  slamd::clients::RegisterBench(app);
  slamd::clients::RegisterReplay(app);
  slamd::clients::RegisterStatus(app);
  slamd::clients::RegisterWatch(app);
  slamd::clients::RegisterQuery(app);
  slamd::clients::RegisterSim(app);
  slamd::clients::RegisterPlot(app);
  slamd::clients::RegisterJournal(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    app.exit(e);
    return slamd::clients::kExitUsage;
  } catch (const slamd::clients::CommandExit& e) {
    return e.code;
  }
  return slamd::clients::kExitOk;
}
