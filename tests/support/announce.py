"""Many devices announcing themselves at once, from one process of their own, for the
discovery tests and benchmarks: `python -m tests.support.announce COUNT [INTERFACE]`.

Each device has its own responder (as each would on its own board). Prints one line
`{"ready": COUNT, "uuids": [...]}` once all are announced, and says goodbye and exits when
its stdin closes."""

from __future__ import annotations

import asyncio
import json
import resource
import sys
import uuid

from openpendant.runtime.kit.discovery import Advertisement, make_zeroconf


async def announce(count: int, interface: str) -> None:
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    resource.setrlimit(resource.RLIMIT_NOFILE, (min(hard, max(soft, 8 * count + 256)), hard))
    responders = [make_zeroconf([interface]) for _ in range(count)]
    ads = [
        Advertisement(
            uuid=f"burst-{uuid.uuid4()}",
            kind="robot",
            model="burst",
            name=f"burst {i}",
            host=interface,
            port=20000 + i,
            key="",
        )
        for i in range(count)
    ]
    sent = await asyncio.gather(
        *(
            zc.async_register_service(ad.service_info(), cooperating_responders=True)
            for zc, ad in zip(responders, ads, strict=True)
        )
    )
    await asyncio.gather(*sent)
    print(json.dumps({"ready": count, "uuids": [ad.uuid for ad in ads]}), flush=True)
    await asyncio.get_running_loop().run_in_executor(None, sys.stdin.read)
    await asyncio.gather(*(zc.async_close() for zc in responders))


if __name__ == "__main__":
    asyncio.run(announce(int(sys.argv[1]), sys.argv[2] if len(sys.argv) > 2 else "127.0.0.1"))
