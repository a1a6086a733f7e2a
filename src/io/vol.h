/*
 * io/vol.h: Mitsuba's binary volume grids (.vol), read into a medium volume (medium/medium.h).
 */
#ifndef SPC_IO_VOL_H
#define SPC_IO_VOL_H

#include "core/error.h"
#include "medium/medium.h"

/* Grids beyond this many values (cells x channels) are refused with SPC_ERR_LIMIT. */
#define SPC_VOL_MAX_VALUES (1ull << 30)

/* Reads the grid of `path` into v: res, channels (1 or 3), data (malloc'ed: the caller owns it,
 * freed by spc_medium_release once in a medium), and in bbox (may be NULL) the file's bounding box
 * (xmin, ymin, zmin, xmax, ymax, zmax). v's other fields are left as they are. Errors name the
 * file: SPC_ERR_IO (unreadable), SPC_ERR_PARSE (not a version 3 float32 .vol, truncated, a value
 * not finite), SPC_ERR_VALUE (channels other than 1 or 3, a size not positive), SPC_ERR_LIMIT,
 * SPC_ERR_NOMEM. */
spc_status spc_vol_read(const char *path, spc_volume *v, double bbox[6], spc_error *err);

#endif
