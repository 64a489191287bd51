#pragma once
// Child processes of fragsimd's external backends (server/backend.h): started in a session of
// their own and watched by process group.
#include <sys/types.h>

#include <cstdint>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

namespace fragsim::server {

// Starts `argv` in a session of its own (its process group id = its pid), stdin from /dev/null,
// stdout and stderr to the files given (empty: /dev/null), in `cwd`, with `env` added to the
// daemon's environment, every signal unblocked and at its default and no descriptor of the
// daemon's open. Returns once the child is in its own session. Throws when the program cannot
// be found or run.
pid_t spawn(const std::vector<std::string>& argv, const std::filesystem::path& out,
            const std::filesystem::path& err, const std::filesystem::path& cwd,
            const std::vector<std::pair<std::string, std::string>>& env);
// Waits for `pid` at most `timeout_s`: its exit status, 128 + signal, -1 (error) or -2 (timed
// out: its process group is then killed).
int wait_for(pid_t pid, double timeout_s);
// Reaps the group's members that are this process's children (zombies otherwise).
void reap_group(pid_t pgid);
// When the process started (field 22 of /proc/<pid>/stat, clock ticks since boot); 0 if none.
std::uint64_t process_start_time(pid_t pid);
// `name` on PATH ("" when not found); a name with a '/' is returned as it is.
std::string find_program(const std::string& name);

}  // namespace fragsim::server
