/* A test fixture, never shipped: bcryptprimitives.dll with ProcessPrng for wine 8, which lacks
 * it (Windows 10 and later have it; Rust's std imports it for its random hash seeds). Forwards
 * to BCryptGenRandom with the system's preferred generator. tools/windows.sh builds it with
 * MinGW and puts it beside the test master under wine (WINEDLLOVERRIDES bcryptprimitives=n,b).
 */
#include <windows.h>
#include <bcrypt.h>

BOOL WINAPI ProcessPrng(PBYTE data, SIZE_T len) {
    while (len > 0) {
        ULONG n = len > 0x40000000 ? 0x40000000 : (ULONG)len;
        if (!BCRYPT_SUCCESS(BCryptGenRandom(NULL, data, n, BCRYPT_USE_SYSTEM_PREFERRED_RNG))) return FALSE;
        data += n;
        len -= n;
    }
    return TRUE;
}
