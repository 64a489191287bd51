// Placeholder replaced below by the rewrite for tally/stratified_tally.h.
#include "core/tally/stratified_tally.h"
