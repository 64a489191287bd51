// The served OpenAPI document checked by standard tools (tests/server/openapi/run.sh):
//   1. @seriousme/openapi-schema-validator: the document validates against the OpenAPI 3.1
//      schema (with its JSON Schema 2020-12 dialect) and every $ref resolves;
// then run.sh generates TypeScript types with openapi-typescript and type-checks client.ts.
import { Validator } from "@seriousme/openapi-schema-validator";

const [served] = process.argv.slice(2);
let failed = false;

async function check(label, validate) {
  const res = await validate();
  if (res.valid) {
    console.error(`openapi: ${label}: valid OpenAPI ${res.version}, every $ref resolves`);
  } else {
    failed = true;
    console.error(`openapi: ${label}: NOT valid`);
    console.error(JSON.stringify(res.errors, null, 2).slice(0, 4000));
  }
}

await check(served, async () => {
  const v = new Validator();
  const res = await v.validate(served);
  if (res.valid) {
    // Every $ref of the self-contained document points at something in it.
    try {
      v.resolveRefs();
    } catch (e) {
      return { valid: false, errors: [String(e)] };
    }
  }
  return { ...res, version: v.version };
});

process.exit(failed ? 1 : 0);
