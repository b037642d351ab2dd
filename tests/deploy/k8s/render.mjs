// Renders deploy/k8s without kubectl and validates the objects offline (tests/deploy_test.sh).
//
//   node render.mjs render KUSTOMIZATION_DIR OUT.yaml [CONFIG_OUT]
//       Renders the kustomization (the subset of kustomize it uses, below) to OUT.yaml, then
//       validates it as `validate` does; CONFIG_OUT receives the generated ConfigMap's
//       shrmd.conf (so that the test can start shrmd with it).
//   node render.mjs validate RENDERED.yaml
//       Validates every object of a multi-document YAML file: the Kubernetes JSON schema of its
//       apiVersion/kind (npm kubernetes-models, Kubernetes 1.27), no field the schema does not
//       know (a typo such as `readinesProbe` is otherwise silently dropped by the API server),
//       and shrmd's deployment rules (checkShrm below).
//   node render.mjs compare A.yaml B.yaml
//       The same set of objects (by kind/namespace/name, deep-equal), e.g. this renderer's
//       output and `kubectl kustomize`'s.
//
// Kustomize subset: `resources` (files), `namespace`, `labels` (pairs, includeSelectors,
// includeTemplates), `configMapGenerator` (files, literals; kustomize's content-hash name suffix,
// and name references to it from pod templates). Anything else is refused, so the renderer
// never silently differs from kustomize. Prints one PASS/FAIL line per check; exit 1 on any
// FAIL, 2 on usage errors.
import { createHash } from "node:crypto";
import { readFileSync, writeFileSync } from "node:fs";
import { basename, join } from "node:path";
import { parseAllDocuments, stringify } from "yaml";

let failures = 0;
const pass = (msg) => console.log(`PASS: ${msg}`);
const fail = (msg) => {
  console.log(`FAIL: ${msg}`);
  failures++;
};
const check = (ok, msg) => (ok ? pass(msg) : fail(msg));

function loadYamlDocs(path) {
  const docs = parseAllDocuments(readFileSync(path, "utf8"));
  const out = [];
  for (const d of docs) {
    if (d.errors.length) throw new Error(`${path}: ${d.errors[0].message}`);
    const v = d.toJS();
    if (v !== null && v !== undefined) out.push(v);
  }
  return out;
}

// Cluster-scoped kinds among those a kustomization of this project could hold.
const CLUSTER_SCOPED = new Set([
  "Namespace", "ClusterRole", "ClusterRoleBinding", "CustomResourceDefinition",
  "PersistentVolume", "PriorityClass", "StorageClass", "ValidatingWebhookConfiguration",
  "MutatingWebhookConfiguration",
]);

// kustomize's ConfigMap name suffix (api/hasher): sha256 over Go's json.Marshal of
// {"data", "kind", "name"} (sorted keys, HTML characters escaped), first 10 hex digits with
// 0 1 3 a e replaced by g h k m t. kustomize v5 (kubectl >= 1.27) looks the name up with a
// path it does not find, so "name" is always "" (checked against `kubectl kustomize` 5.5).
function goJson(value) {
  if (typeof value === "string") {
    if (/[\b\f]/.test(value)) throw new Error("\\b or \\f in ConfigMap data: not supported");
    return JSON.stringify(value)
      .replace(/</g, "\\u003c")
      .replace(/>/g, "\\u003e")
      .replace(/&/g, "\\u0026")
      .replace(/\u2028/g, "\\u2028")
      .replace(/\u2029/g, "\\u2029");
  }
  if (value && typeof value === "object") {
    const keys = Object.keys(value).sort();
    return `{${keys.map((k) => `${goJson(k)}:${goJson(value[k])}`).join(",")}}`;
  }
  return JSON.stringify(value);
}
function configMapHash(data) {
  const hex = createHash("sha256")
    .update(goJson({ data, kind: "ConfigMap", name: "" }))
    .digest("hex");
  const map = { 0: "g", 1: "h", 3: "k", a: "m", e: "t" };
  return [...hex.slice(0, 10)].map((c) => map[c] ?? c).join("");
}

function podSpecs(obj) {
  const spec = obj.spec ?? {};
  if (obj.kind === "Pod") return [spec];
  if (spec.template?.spec) return [spec.template.spec];
  if (spec.jobTemplate?.spec?.template?.spec) return [spec.jobTemplate.spec.template.spec];
  return [];
}

function renameConfigMapRefs(obj, renames) {
  const fix = (ref) => {
    if (ref && renames.has(ref.name)) ref.name = renames.get(ref.name);
  };
  for (const pod of podSpecs(obj)) {
    for (const v of pod.volumes ?? []) {
      fix(v.configMap);
      for (const s of v.projected?.sources ?? []) fix(s.configMap);
    }
    for (const c of [...(pod.containers ?? []), ...(pod.initContainers ?? [])]) {
      for (const e of c.envFrom ?? []) fix(e.configMapRef);
      for (const e of c.env ?? []) fix(e.valueFrom?.configMapKeyRef);
    }
  }
}

function render(dir) {
  const k = loadYamlDocs(join(dir, "kustomization.yaml"))[0];
  const known = new Set([
    "apiVersion", "kind", "namespace", "labels", "resources", "configMapGenerator",
  ]);
  for (const key of Object.keys(k)) {
    if (!known.has(key)) throw new Error(`kustomization.yaml: '${key}' is not supported by this renderer`);
  }
  const objects = [];
  for (const r of k.resources ?? []) objects.push(...loadYamlDocs(join(dir, r)));

  const renames = new Map();
  for (const g of k.configMapGenerator ?? []) {
    for (const key of Object.keys(g)) {
      if (!["name", "files", "literals"].includes(key))
        throw new Error(`configMapGenerator: '${key}' is not supported by this renderer`);
    }
    const data = {};
    for (const f of g.files ?? []) {
      const [key, path] = f.includes("=") ? f.split(/=(.*)/s) : [basename(f), f];
      data[key] = readFileSync(join(dir, path), "utf8");
    }
    for (const l of g.literals ?? []) {
      const [key, value] = l.split(/=(.*)/s);
      data[key] = value;
    }
    const name = `${g.name}-${configMapHash(data)}`;
    renames.set(g.name, name);
    objects.push({ apiVersion: "v1", kind: "ConfigMap", metadata: { name }, data });
  }

  for (const obj of objects) {
    obj.metadata ??= {};
    if (k.namespace && !CLUSTER_SCOPED.has(obj.kind)) obj.metadata.namespace = k.namespace;
    for (const l of k.labels ?? []) {
      for (const key of Object.keys(l)) {
        if (!["pairs", "includeSelectors", "includeTemplates"].includes(key))
          throw new Error(`labels: '${key}' is not supported by this renderer`);
      }
      obj.metadata.labels = { ...(obj.metadata.labels ?? {}), ...l.pairs };
      if (l.includeTemplates || l.includeSelectors) {
        for (const tmpl of obj.spec?.template ? [obj.spec.template] : []) {
          tmpl.metadata ??= {};
          tmpl.metadata.labels = { ...(tmpl.metadata.labels ?? {}), ...l.pairs };
        }
      }
      if (l.includeSelectors) {
        if (obj.spec?.selector?.matchLabels)
          Object.assign(obj.spec.selector.matchLabels, l.pairs);
        else if (obj.kind === "Service" && obj.spec?.selector)
          Object.assign(obj.spec.selector, l.pairs);
      }
    }
    renameConfigMapRefs(obj, renames);
  }
  return objects;
}

// Schema validation, plus unknown fields: the compiled validators read every property their
// schema knows (and every key of maps), so a property the validator never read is unknown.
async function validateObject(obj) {
  const id = `${obj.kind}/${obj.metadata?.name}`;
  let mod;
  try {
    mod = await import(`kubernetes-models/${obj.apiVersion}`);
  } catch {
    fail(`${id}: unknown apiVersion ${obj.apiVersion}`);
    return;
  }
  const Model = mod[obj.kind];
  if (!Model) {
    fail(`${id}: unknown kind ${obj.kind} in ${obj.apiVersion}`);
    return;
  }
  const seen = new Set();
  const track = (value, path) =>
    value === null || typeof value !== "object"
      ? value
      : new Proxy(value, {
          get(target, key, receiver) {
            if (typeof key === "string") seen.add(`${path}/${key}`);
            return track(Reflect.get(target, key, receiver), `${path}/${key}`);
          },
        });
  try {
    Model.prototype.validate.call(track(obj, ""));
  } catch (e) {
    fail(`${id}: schema (${obj.apiVersion}): ${e.message}`);
    return;
  }
  const unknown = [];
  const walk = (value, path) => {
    if (value === null || typeof value !== "object") return;
    for (const key of Object.keys(value)) {
      const p = `${path}/${key}`;
      if (!seen.has(p)) unknown.push(p);
      else walk(value[key], p);
    }
  };
  walk(obj, "");
  if (unknown.length) fail(`${id}: fields unknown to the ${obj.apiVersion} ${obj.kind} schema: ${unknown.join(", ")}`);
  else pass(`${id}: valid ${obj.apiVersion} ${obj.kind} (Kubernetes 1.27 schema, no unknown fields)`);
}

const matches = (selector, labels) =>
  !!selector && Object.entries(selector).every(([k, v]) => labels?.[k] === v);

// shrmd's rules (issue 6): what a schema cannot say.
function checkShrm(objects) {
  const one = (kind) => objects.filter((o) => o.kind === kind);
  const [dep] = one("Deployment");
  if (!dep) return fail("no Deployment");
  const pod = dep.spec.template.spec;
  const podLabels = dep.spec.template.metadata?.labels ?? {};
  const c = pod.containers.find((x) => x.name === "shrmd") ?? pod.containers[0];
  const ru = dep.spec.strategy?.rollingUpdate ?? {};
  check(
    dep.spec.strategy?.type === "RollingUpdate" && String(ru.maxUnavailable) === "0" &&
      String(ru.maxSurge ?? "25%") !== "0",
    "Deployment: rolling update without unavailability (maxUnavailable 0, maxSurge > 0)",
  );
  check(
    pod.securityContext?.runAsNonRoot === true && Number(pod.securityContext?.runAsUser) > 0,
    "Deployment: runs as a non-root user",
  );
  check(
    c.securityContext?.readOnlyRootFilesystem === true &&
      c.securityContext?.allowPrivilegeEscalation === false &&
      (c.securityContext?.capabilities?.drop ?? []).includes("ALL"),
    "Deployment: read-only root filesystem, no privilege escalation, capabilities dropped",
  );
  const r = c.resources ?? {};
  check(
    r.requests?.memory && r.limits?.memory && r.requests?.cpu,
    "Deployment: memory request and limit, CPU request (the HPA needs it)",
  );
  const grpcPort = (c.ports ?? []).find((p) => p.name === "grpc")?.containerPort;
  check(
    c.readinessProbe?.grpc?.service === "shrm.v1.readiness" &&
      c.readinessProbe?.grpc?.port === grpcPort,
    "Deployment: gRPC readiness probe on shrm.v1.readiness at the grpc port",
  );
  check(
    c.livenessProbe?.grpc?.service === "shrm.v1.liveness" &&
      c.livenessProbe?.grpc?.port === grpcPort,
    "Deployment: gRPC liveness probe on shrm.v1.liveness at the grpc port",
  );
  // The config file: mounted from the generated ConfigMap where --config points.
  const args = [...(c.command ?? []), ...(c.args ?? [])];
  const configPath = args[args.indexOf("--config") + 1];
  const cmVolume = (pod.volumes ?? []).find((v) => v.configMap);
  const cm = objects.find((o) => o.kind === "ConfigMap" && o.metadata.name === cmVolume?.configMap?.name);
  const mount = (c.volumeMounts ?? []).find((m) => m.name === cmVolume?.name);
  const confKey = cm && Object.keys(cm.data ?? {}).find((key) => `${mount?.mountPath}/${key}` === configPath);
  check(confKey, `Deployment: --config ${configPath} is a key of the ConfigMap mounted from ${cmVolume?.configMap?.name}`);
  const conf = {};
  for (const line of (confKey ? cm.data[confKey] : "").split("\n")) {
    const m = line.match(/^\s*([^#=\s][^=]*?)\s*=\s*(.*?)\s*$/);
    if (m) conf[m[1]] = m[2].replace(/^"(.*)"$/, "$1");
  }
  const listenPort = Number((conf.listen ?? "").split(":").pop());
  check(listenPort === grpcPort, `ConfigMap: listen port ${listenPort} = the container's grpc port ${grpcPort}`);
  const secret = (pod.volumes ?? []).find((v) => v.secret);
  check(secret?.secret?.secretName && (c.volumeMounts ?? []).some((m) => m.name === secret.name),
    `Deployment: Secret ${secret?.secret?.secretName} (TLS material, tokens) mounted`);
  const spool = (c.volumeMounts ?? []).find((m) => m.mountPath === conf["spool-dir"]);
  check(spool, `Deployment: the spool directory ${conf["spool-dir"]} is a writable volume`);
  const preStop = (c.lifecycle?.preStop?.exec?.command ?? []).map(Number).find((x) => x > 0) ?? 0;
  const grace = Number(conf["grace-period"] ?? 30);
  check(
    (pod.terminationGracePeriodSeconds ?? 30) > grace + preStop,
    `Deployment: terminationGracePeriodSeconds ${pod.terminationGracePeriodSeconds} > preStop ${preStop} s + grace-period ${grace} s`,
  );
  check(!("replicas" in dep.spec), "Deployment: no replicas field (the HPA owns the count)");

  const svc = one("Service").find((s) => s.spec?.clusterIP === "None");
  check(
    svc && matches(svc.spec.selector, podLabels) &&
      svc.spec.ports.some((p) => p.port === grpcPort || p.targetPort === "grpc"),
    "Service: headless (clusterIP None), selects the pods, serves the grpc port",
  );
  const [pdb] = one("PodDisruptionBudget");
  check(pdb && matches(pdb.spec.selector?.matchLabels, podLabels),
    "PodDisruptionBudget: selects the pods");
  const [hpa] = one("HorizontalPodAutoscaler");
  check(
    hpa && hpa.spec.scaleTargetRef.kind === "Deployment" &&
      hpa.spec.scaleTargetRef.name === dep.metadata.name &&
      hpa.spec.metrics.some((m) => m.resource?.name === "cpu"),
    "HorizontalPodAutoscaler: scales the Deployment on CPU",
  );
  check(pdb && hpa && (hpa.spec.minReplicas ?? 1) > Number(pdb.spec.maxUnavailable ?? 0),
    "PodDisruptionBudget: leaves pods serving at the HPA's minimum");
  return confKey ? cm.data[confKey] : null;
}

async function validateAll(objects) {
  check(objects.length > 0, `${objects.length} objects`);
  for (const obj of objects) await validateObject(obj);
  return checkShrm(objects);
}

function identity(o) {
  return `${o.kind}/${o.metadata?.namespace ?? ""}/${o.metadata?.name}`;
}
const canonical = (v) =>
  Array.isArray(v)
    ? v.map(canonical)
    : v && typeof v === "object"
      ? Object.fromEntries(Object.keys(v).sort().map((k) => [k, canonical(v[k])]))
      : v;

async function main(argv) {
  const [cmd, ...args] = argv;
  if (cmd === "render" && (args.length === 2 || args.length === 3)) {
    const objects = render(args[0]);
    writeFileSync(args[1], objects.map((o) => stringify(o)).join("---\n"));
    pass(`rendered ${args[0]} without kubectl: ${objects.length} objects -> ${args[1]}`);
    const conf = await validateAll(objects);
    if (args[2] && conf !== null) writeFileSync(args[2], conf);
  } else if (cmd === "validate" && args.length === 1) {
    await validateAll(loadYamlDocs(args[0]));
  } else if (cmd === "compare" && args.length === 2) {
    const [a, b] = args.map((f) => new Map(loadYamlDocs(f).map((o) => [identity(o), o])));
    const ids = new Set([...a.keys(), ...b.keys()]);
    const differ = [...ids].filter(
      (id) => JSON.stringify(canonical(a.get(id))) !== JSON.stringify(canonical(b.get(id))),
    );
    check(differ.length === 0,
      `${args[0]} and ${args[1]}: the same ${ids.size} objects${differ.length ? `; differ: ${differ.join(", ")}` : ""}`);
  } else {
    console.error("usage: render.mjs render DIR OUT.yaml [CONFIG_OUT] | validate FILE | compare A B");
    return 2;
  }
  return failures ? 1 : 0;
}

main(process.argv.slice(2)).then(
  (code) => process.exit(code),
  (e) => {
    console.log(`FAIL: ${e.message}`);
    process.exit(1);
  },
);
