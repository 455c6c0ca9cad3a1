#pragma once
// An X display for VTK's offscreen rendering: DISPLAY when it answers, else an Xvfb started for this process.

namespace gpisvdb {

/// Makes DISPLAY name a usable X server, starting Xvfb (in its own process group, killed when this process
/// ends) when none answers. Throws OutputError when neither works.
void ensureDisplay();

}  // namespace gpisvdb
